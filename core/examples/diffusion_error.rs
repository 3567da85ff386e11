//! The diffusion mode against volumetric path tracing: one milky-water scene (a large, thick,
//! highly scattering box and a thin slab of the same water under a uniform sky), three regions
//! (flat centre, the band along an edge, the thin slab), each rendered with
//! `method = volumetric` (the reference) and `diffusion`; prints the mean radiance of each,
//! the relative error and the render times as a Markdown table.
//!
//! `cargo run --release -p tide-core --example diffusion_error [spp_reference] [spp_diffusion]`

use glam::{Mat4, Vec3};
use std::time::Instant;
use tide_core::scene::*;
use tide_core::{Aov, RenderSettings, Renderer};

// the render tests' scene builders (box_mesh, look_at, …)
#[path = "../tests/common.rs"]
mod common;
use common::{box_mesh, look_at};

/// Milky water: σs = 10 /m, σa = 0.5 /m (albedo 0.95), isotropic, IOR 1.333. The thick box is
/// 8 × 2 × 8 m (top at y = 0, 20 mean free paths deep); the thin slab 0.1 m (one mean free
/// path) thick, 2 × 2 m, at x = 10. A uniform white sky of radiance 1.
pub fn scene(method: MediumMethod, target: Vec3, view_width: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(box_mesh("/body", Vec3::new(-4.0, -2.0, -4.0), Vec3::new(4.0, 0.0, 4.0))));
    s.meshes.push(std::sync::Arc::new(box_mesh("/slab", Vec3::new(9.0, -0.1, -1.0), Vec3::new(11.0, 0.0, 1.0))));
    s.media.push(MediumDesc { name: "/milk".into(), sigma_a: SpectrumDesc::Rgb([0.5; 3]), sigma_s: SpectrumDesc::Rgb([10.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.333, ..Default::default() }), interior_medium: Some(0) });
    for (i, n) in ["/body", "/slab"].iter().enumerate() {
        s.instances_mut().push(InstanceDesc { name: (*n).into(), geometry: GeometryRef::Mesh(i), transforms: vec![Mat4::IDENTITY], times: vec![0.0], material: 0, id: i as u32, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None });
    }
    // a uniform white sky of radiance 1 (irradiance π on the top): escaping paths of the
    // volumetric reference always find it, so the reference converges
    s.lights.push(LightDesc { name: "/sky".into(), shape: LightShape::Dome { texture: None }, transform: Mat4::IDENTITY, color: [1.0; 3], intensity: 1.0, exposure: 0.0, normalize: false, color_temperature: None, visible_to_camera: false, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() });
    // straight down onto `target`, the view `view_width` wide at the surface
    let eye = target + Vec3::Y * 4.0;
    let focal = 50.0;
    let ap = focal * view_width / 4.0;
    s.camera = CameraDesc { transforms: vec![look_at(eye, target)], focal_length: focal, horizontal_aperture: ap, vertical_aperture: ap, clipping_range: [1e-3, 1e6], ..Default::default() };
    s
}

/// The regions: (name, view centre, view width).
pub const REGIONS: [(&str, [f32; 3], f32); 3] = [("flat centre", [0.0, 0.0, 0.0], 1.0), ("edge band (0–0.25 m from an edge)", [3.875, 0.0, 0.0], 0.25), ("thin slab (0.1 m, 1 mfp)", [10.0, 0.0, 0.0], 1.0)];

fn mean_luminance(r: &Renderer) -> f64 {
    let px = r.aov_pixels(Aov::Color);
    let n = px.len() / 4;
    px.chunks_exact(4).map(|p| (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) as f64).sum::<f64>() / n as f64
}

fn main() {
    let args: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let spp_ref = args.first().copied().unwrap_or(256);
    let spp_dif = args.get(1).copied().unwrap_or(16);
    println!("| region | volumetric (spp {spp_ref}) | time | diffusion (spp {spp_dif}) | time | relative error |");
    println!("|---|---|---|---|---|---|");
    for (name, c, w) in REGIONS {
        let mut row = Vec::new();
        for (method, spp) in [(MediumMethod::Volumetric, spp_ref), (MediumMethod::Diffusion, spp_dif)] {
            let sc = scene(method, Vec3::from_array(c), w);
            let settings = RenderSettings { width: 32, height: 32, spp, max_depth: 4096, seed: 3, threads: 0, ..Default::default() };
            let t0 = Instant::now();
            let mut r = Renderer::new(&sc, settings).expect("renderer");
            let t_build = t0.elapsed().as_secs_f64();
            r.render_pass(spp, None);
            eprintln!("{name} {method:?}: build {t_build:.2} s, total {:.2} s", t0.elapsed().as_secs_f64());
            row.push((mean_luminance(&r), t0.elapsed().as_secs_f64()));
        }
        let err = row[1].0 / row[0].0 - 1.0;
        println!("| {name} | {:.4} | {:.2} s | {:.4} | {:.2} s | {:+.1}% |", row[0].0, row[0].1, row[1].0, row[1].1, 100.0 * err);
    }
}
