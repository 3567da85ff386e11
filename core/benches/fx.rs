//! Ray throughput of the water FX primitives against plain spheres on the same points.
//!
//!     cargo bench -p tide-core --bench fx
//!
//! (`TIDE_BENCH_POINTS=N`: N points instead of 20000, e.g. a million droplets;
//! `TIDE_BENCH_SHAPES=spheres,bubbles`: only those shapes, the ratios then left out;
//! `TIDE_BENCH_RAYS=N`: the first N of the rays, for slow cases.)
//!
//! A splash sheet of 20000 points (the shape of `docs/stages/splash.py`'s, radii 1–3 cm) is
//! built three ways: as spheres, as bubbles (h₁ = 0.9 r, h₂ = 0.35 r) and as blobbies
//! (T = 0.5: kernels reach 2.2 r and merge); 200000 incoherent rays (from a sphere around the
//! sheet towards points inside its bounds, seeded) are traced for the closest hit on one
//! thread, best of 3 passes. Prints one JSON line: Mrays/s and hit fraction per shape, the
//! blobby/sphere and bubble/sphere throughput ratios, and how many of 256 blobby hits agree with
//! the direct intersection over all kernels (the BVH's candidate gathering checked).

mod common;
use common::Rng;
use glam::{Mat4, Quat, Vec3};
use std::time::Instant;
use tide_core::accel::implicit::{blobby_intersect, Kernel};
use tide_core::accel::{Accel, Ray};
use tide_core::scene::{GeometryRef, InstanceDesc, PointShape, SpheresDesc};

fn sheet(n: usize, rng: &mut Rng) -> SpheresDesc {
    let mut s = SpheresDesc { name: "/Splash".into(), ..Default::default() };
    for _ in 0..n {
        let t = rng.next();
        let a = rng.next() - 0.5;
        let p = Vec3::new(0.7 + 1.3 * t, 0.2 + 1.6 * t - 1.1 * t * t, a * (0.4 + 0.8 * t));
        s.centers.push(p + (Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 0.04);
        s.radii.push(0.01 + 0.02 * rng.next());
    }
    s
}

fn time_rays(accel: &Accel, rays: &[Ray]) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..3 {
        let t = Instant::now();
        hits = rays.iter().filter(|r| accel.intersect(r).is_some()).count();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (rays.len() as f64 / best / 1e6, hits as f64 / rays.len() as f64)
}

fn main() {
    let mut rng = Rng(0x243f_6a88_85a3_08d3);
    let count = std::env::var("TIDE_BENCH_POINTS").ok().map_or(20_000, |s| s.parse().expect("TIDE_BENCH_POINTS"));
    let shapes = std::env::var("TIDE_BENCH_SHAPES").unwrap_or_else(|_| "spheres,bubbles,blobbies".into());
    let spheres = sheet(count, &mut rng);
    let n = spheres.centers.len();
    let bubbles = SpheresDesc {
        shape: PointShape::Bubbles {
            top: spheres.radii.iter().map(|r| 0.9 * r).collect(),
            bottom: spheres.radii.iter().map(|r| 0.35 * r).collect(),
            orientations: None,
        },
        ..spheres.clone()
    };
    let threshold = 0.5;
    let blobby = SpheresDesc { shape: PointShape::Blobby { threshold, orientations: None, scales: None }, ..spheres.clone() };
    let (lo, hi) = spheres.centers.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), &c| (a.min(c), b.max(c)));
    let center = 0.5 * (lo + hi);
    let radius = (hi - lo).length();
    let count_rays: usize = std::env::var("TIDE_BENCH_RAYS").ok().map_or(200_000, |s| s.parse().expect("TIDE_BENCH_RAYS"));
    let rays: Vec<Ray> = (0..count_rays)
        .map(|_| {
            let o = center + rng.dir() * radius;
            let target = lo + (hi - lo) * Vec3::new(rng.next(), rng.next(), rng.next());
            Ray { o, d: (target - o).normalize(), t_max: f32::INFINITY, time: 0.0 }
        })
        .collect();
    let inst = vec![InstanceDesc {
        name: "/Splash".into(),
        geometry: GeometryRef::Spheres(0),
        transforms: vec![Mat4::IDENTITY],
        times: vec![0.0],
        material: 0,
        id: 0,
        visible_to_camera: true,
        casts_shadows: true,
        primvar_row: None,
        index: None,
    }];
    let mut out = Vec::new();
    let mut rates = Vec::new();
    for (name, s) in [("spheres", &spheres), ("bubbles", &bubbles), ("blobbies", &blobby)] {
        if !shapes.split(',').any(|x| x == name) {
            continue;
        }
        let s = [std::sync::Arc::new(s.clone())];
        let t = Instant::now();
        let accel = Accel::build(&[], &s, &inst, (0.0, 0.0));
        let build = t.elapsed().as_secs_f64();
        let (mrays, frac) = time_rays(&accel, &rays);
        rates.push(mrays);
        out.push(format!("\"{name}_mrays_s\": {mrays:.4}, \"{name}_hit_fraction\": {frac:.4}, \"{name}_build_s\": {build:.3}"));
        if name == "blobbies" {
            // the BVH path against all kernels at once
            let kernels: Vec<Kernel> = (0..n).map(|i| Kernel::new(spheres.centers[i], spheres.radii[i], Vec3::ONE, Quat::IDENTITY, threshold)).collect();
            let agree = rays[..256]
                .iter()
                .filter(|r| {
                    let a = accel.intersect(r).map(|h| h.t);
                    let b = blobby_intersect(&kernels, threshold, r.o, r.d, 0.0, f32::INFINITY).map(|h| h.0);
                    match (a, b) {
                        (Some(x), Some(y)) => (x - y).abs() <= 1e-4 * (1.0 + y),
                        (None, None) => true,
                        _ => false,
                    }
                })
                .count();
            out.push(format!("\"blobby_hits_agreeing_with_all_kernels\": \"{agree}/256\""));
        }
    }
    if rates.len() == 3 {
        out.push(format!("\"bubbles_over_spheres\": {:.3}, \"blobbies_over_spheres\": {:.3}", rates[1] / rates[0], rates[2] / rates[0]));
    }
    println!("{{\"points\": {n}, \"rays\": {}, \"threads\": 1, {}}}", rays.len(), out.join(", "));
}
