//! Sync cost at the Rust level (delegate only, no USD, no Python): the time and peak memory
//! of handing a big prim to the delegate, of `commit_resources` (conversion + scene assembly)
//! and of the core build (`Renderer::new`: validation, BVH, world), and the re-sync of a
//! 1000-prim scene after moving one prim.
//!
//!     cargo bench -p tide-delegate --bench front_door_sync -- CASE [REPEATS]
//!
//! CASE: `mesh2m` (a 1000×1000-quad grid: 2M triangles), `points1m` (1M points with widths),
//! `resync1000` (1000 meshes of 200 triangles; one is moved). Prints one JSON object per
//! repeat; peak RSS is the process's VmHWM after each phase (it only grows, so run one case
//! per process). `bench/front_door_rust.sh` runs every case and takes medians.
//!
//! Core builds pass one [`BuildCache`] along, as the delegate's render passes do: after the
//! first build, `mesh2m` / `points1m` move the prim and rebuild (`move_*`), `resync1000`
//! moves one of its meshes.

use std::time::Instant;
use tide_core::world::BuildCache;
use tide_core::{RenderSettings, Renderer};
use tide_delegate::{Delegate, Value};

fn vm_hwm_mib() -> f64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|k| k.parse::<f64>().ok())
        .map_or(0.0, |kib| kib / 1024.0)
}

fn grid(n: usize, offset: [f32; 3]) -> (Vec<f32>, Vec<i32>, Vec<i32>) {
    let mut pts = Vec::with_capacity((n + 1) * (n + 1) * 3);
    for j in 0..=n {
        for i in 0..=n {
            pts.extend_from_slice(&[offset[0] + i as f32 / n as f32, offset[1], offset[2] + j as f32 / n as f32]);
        }
    }
    let mut idx = Vec::with_capacity(n * n * 4);
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as i32;
            let b = a + (n + 1) as i32;
            idx.extend_from_slice(&[a, b, b + 1, a + 1]);
        }
    }
    (pts, vec![4; n * n], idx)
}

fn translate(x: f64) -> Value {
    let mut m = [0.0; 16];
    for i in 0..4 {
        m[5 * i] = 1.0;
    }
    m[12] = x;
    Value::Matrix(m)
}

fn add_mesh(d: &mut Delegate, path: &str, n: usize, offset: [f32; 3]) {
    let (pts, counts, idx) = grid(n, offset);
    d.create_prim("mesh", path);
    d.set_attribute(path, "points", Value::Floats { data: pts, tuple: 3 }, None);
    d.set_attribute(path, "faceVertexCounts", Value::Ints(counts), None);
    d.set_attribute(path, "faceVertexIndices", Value::Ints(idx), None);
}

fn add_camera(d: &mut Delegate) {
    d.create_prim("camera", "/cam");
    let mut m = [0.0; 16];
    for i in 0..4 {
        m[5 * i] = 1.0;
    }
    m[13] = 0.5;
    m[14] = 3.0;
    d.set_attribute("/cam", "transform", Value::Matrix(m), None);
}

fn settings() -> RenderSettings {
    RenderSettings { width: 64, height: 36, spp: 1, ..Default::default() }
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

fn run(case: &str) -> String {
    let base = vm_hwm_mib();
    let mut d = Delegate::new();
    add_camera(&mut d);
    match case {
        "mesh2m" | "points1m" => {
            let t = Instant::now();
            if case == "mesh2m" {
                add_mesh(&mut d, "/Grid", 1000, [0.0; 3]);
            } else {
                let n = 1_000_000usize;
                let pts: Vec<f32> = (0..n).flat_map(|i| [(i % 1000) as f32 * 1e-3, ((i / 1000) % 1000) as f32 * 1e-3, 0.0]).collect();
                d.create_prim("points", "/Pts");
                d.set_attribute("/Pts", "points", Value::Floats { data: pts, tuple: 3 }, None);
                d.set_primvar("/Pts", "widths", "vertex", vec![1e-3; n], 1, None);
            }
            let author = secs(t);
            let hwm_author = vm_hwm_mib();
            let t = Instant::now();
            let problems = d.commit_resources();
            let commit = secs(t);
            let hwm_commit = vm_hwm_mib();
            let cache = BuildCache::default();
            let t = Instant::now();
            let r = Renderer::with_cache(d.scene(), settings(), Some(&cache)).expect("renderer");
            let build = secs(t);
            let hwm_build = vm_hwm_mib();
            let st = r.build_stats().clone();
            drop(r);
            let path = if case == "mesh2m" { "/Grid" } else { "/Pts" };
            d.set_attribute(path, "transform", translate(0.25), None);
            let t = Instant::now();
            d.commit_resources();
            let move_commit = secs(t);
            let t = Instant::now();
            let r = Renderer::with_cache(d.scene(), settings(), Some(&cache)).expect("renderer");
            let move_build = secs(t);
            let mst = r.build_stats();
            format!(
                "{{\"case\":\"{case}\",\"author_s\":{author:.4},\"commit_s\":{commit:.4},\"core_build_s\":{build:.4},\"bvh_s\":{:.4},\"triangles\":{},\"spheres\":{},\"problems\":{},\"hwm_base_mib\":{base:.1},\"hwm_author_mib\":{hwm_author:.1},\"hwm_commit_mib\":{hwm_commit:.1},\"hwm_build_mib\":{hwm_build:.1},\"move_commit_s\":{move_commit:.4},\"move_core_build_s\":{move_build:.4},\"move_blas_built\":{},\"move_blas_reused\":{}}}",
                st.seconds,
                st.triangles,
                st.spheres,
                problems.len(),
                mst.blas_built,
                mst.blas_reused
            )
        }
        "resync1000" => {
            for k in 0..1000 {
                add_mesh(&mut d, &format!("/World/M{k:04}"), 10, [(k % 40) as f32 * 1.1, 0.0, (k / 40) as f32 * 1.1]);
            }
            let t = Instant::now();
            d.commit_resources();
            let commit0 = secs(t);
            let synced0 = d.last_synced().len();
            let cache = BuildCache::default();
            let t = Instant::now();
            drop(Renderer::with_cache(d.scene(), settings(), Some(&cache)).expect("renderer"));
            let build0 = secs(t);
            d.set_attribute("/World/M0500", "transform", translate(0.25), None);
            let t = Instant::now();
            d.commit_resources();
            let commit1 = secs(t);
            let synced1 = d.last_synced().to_vec();
            let t = Instant::now();
            let r = Renderer::with_cache(d.scene(), settings(), Some(&cache)).expect("renderer");
            let build1 = secs(t);
            let (built, reused) = (r.build_stats().blas_built, r.build_stats().blas_reused);
            format!(
                "{{\"case\":\"{case}\",\"commit_initial_s\":{commit0:.5},\"core_build_initial_s\":{build0:.4},\"synced_initial\":{synced0},\"commit_resync_s\":{commit1:.5},\"core_build_resync_s\":{build1:.4},\"synced_resync\":{:?},\"resync_blas_built\":{built},\"resync_blas_reused\":{reused}}}",
                synced1
            )
        }
        other => panic!("unknown case '{other}' (mesh2m, points1m, resync1000)"),
    }
}

fn main() {
    // `cargo bench` passes `--bench`; the first other argument is the case.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let case = args.first().map(String::as_str).unwrap_or("mesh2m");
    let repeats: usize = args.get(1).and_then(|r| r.parse().ok()).unwrap_or(1);
    for _ in 0..repeats {
        println!("{}", run(case));
    }
}
