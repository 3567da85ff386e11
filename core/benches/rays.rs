//! Closest-hit throughput of Tide's `Accel` on the ocean mesh and ray sets written by
//! `embree_bench.py gen` (`ocean_vertices.npy`, `ocean_indices.npy`, `rays_{incoherent,coherent}_{o,d}.npy`).
//!
//!     cargo bench -p tide-core --bench rays -- DATA_DIR [THREADS,...]
//!
//! (DATA_DIR may also come from `TIDE_BENCH_DATA`; threads default to `1,2`; each timing is the
//! best of `TIDE_BENCH_REPEATS` passes, default 1; `TIDE_BENCH_CHECKS` rays per set, default 64,
//! are checked by brute force. `TIDE_BENCH_MOTION=A` makes the mesh deform: a second position
//! key, time 1, moves every vertex by a smooth field of amplitude A metres, and each ray gets its
//! own time in [0, 1); the brute force then tests the mesh as it stands at the ray's time.) Prints one JSON
//! line: build seconds, bytes per triangle, and per ray set and thread count Mrays/s and hit
//! fraction. Every run checks that all thread counts give bit-identical hits and that a strided
//! subset of rays agrees with a brute-force search over every triangle; a failed check exits 1.

use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use tide_core::accel::{Accel, Ray};
use tide_core::scene::{GeometryRef, InstanceDesc, MeshDesc};

/// Reads a little-endian .npy file of 4-byte elements (`<f4`, `<i4`, `<u4`) in C order.
fn read_npy_u32(path: &std::path::Path) -> Vec<u32> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY", "{}: not an .npy file", path.display());
    let (hlen, start) = if bytes[6] == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12)
    };
    let header = std::str::from_utf8(&bytes[start..start + hlen]).unwrap();
    assert!(
        header.contains("'<f4'") || header.contains("'<i4'") || header.contains("'<u4'"),
        "{}: need 4-byte little-endian elements, header {header}",
        path.display()
    );
    assert!(header.contains("'fortran_order': False"), "{}: need C order", path.display());
    bytes[start + hlen..].chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

fn read_vec3s(path: &std::path::Path) -> Vec<Vec3> {
    read_npy_u32(path).chunks_exact(3).map(|c| Vec3::new(f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2]))).collect()
}

/// CPU time of the calling thread (Linux; NaN elsewhere).
fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |ns| ns * 1e-9)
}

/// One ray's answer: distance bits and triangle, or `u32::MAX` for a miss.
type Answer = (u32, u32);

/// Ray i's shutter time in a deforming run: well spread over [0, 1), the same on every run.
fn ray_time(i: usize) -> f32 {
    ((i as f64 * 0.618_033_988_749_894_9).fract()) as f32
}

/// The second key of a deforming run: each vertex moved by a smooth field of amplitude `a`
/// (waves' motion over a shutter is centimetres on a mesh of 0.34 m edges).
fn moved(positions: &[Vec3], a: f32) -> Vec<Vec3> {
    positions.iter().map(|p| *p + a * Vec3::new((p.z * 0.3).sin(), (p.x * 0.21 + p.z * 0.17).cos(), (p.x * 0.25).sin())).collect()
}

fn trace(accel: &Accel, o: &[Vec3], d: &[Vec3], motion: bool, out: &mut [Answer]) {
    out.par_chunks_mut(1024).enumerate().for_each(|(c, chunk)| {
        for (k, a) in chunk.iter_mut().enumerate() {
            let i = c * 1024 + k;
            let time = if motion { ray_time(i) } else { 0.0 };
            let ray = Ray { o: o[i], d: d[i], t_max: f32::INFINITY, time };
            *a = match accel.intersect(&ray) {
                Some(h) => (h.t.to_bits(), h.prim),
                None => (0, u32::MAX),
            };
        }
    });
}

/// Closest hit over every triangle (double precision Möller–Trumbore), for checking.
fn brute_force(pos: &[Vec3], idx: &[u32], o: Vec3, d: Vec3) -> Option<(f64, u32)> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    (0..idx.len() / 3)
        .into_par_iter()
        .filter_map(|i| {
            let v = |k: usize| pos[idx[3 * i + k] as usize].as_dvec3();
            let (v0, e1, e2) = (v(0), v(1) - v(0), v(2) - v(0));
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det == 0.0 {
                return None;
            }
            let s = o - v0;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let w = d.dot(q) / det;
            let t = e2.dot(q) / det;
            (u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0).then_some((t, i as u32))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let dir = args.first().cloned().or_else(|| std::env::var("TIDE_BENCH_DATA").ok()).unwrap_or_else(|| {
        eprintln!("usage: rays DATA_DIR [THREADS,...]  (or set TIDE_BENCH_DATA)");
        std::process::exit(2)
    });
    let threads: Vec<usize> = args.get(1).map_or("1,2", |s| s.as_str()).split(',').map(|s| s.parse().expect("thread count")).collect();
    let dir = std::path::Path::new(&dir);
    let repeats: usize = std::env::var("TIDE_BENCH_REPEATS").ok().map_or(1, |s| s.parse().expect("TIDE_BENCH_REPEATS"));
    let checks: usize = std::env::var("TIDE_BENCH_CHECKS").ok().map_or(64, |s| s.parse().expect("TIDE_BENCH_CHECKS"));

    let positions = read_vec3s(&dir.join("ocean_vertices.npy"));
    let indices = read_npy_u32(&dir.join("ocean_indices.npy"));
    let ntri = indices.len() / 3;
    let motion: Option<f32> = std::env::var("TIDE_BENCH_MOTION").ok().map(|s| s.parse().expect("TIDE_BENCH_MOTION"));
    let second = motion.map(|a| moved(&positions, a));
    let mut mesh = MeshDesc { name: "ocean".into(), positions: positions.clone(), indices: indices.clone(), ..Default::default() };
    if let Some(p1) = &second {
        mesh.motion = Some(tide_core::scene::MeshMotion { times: vec![0.0, 1.0], positions: vec![positions.clone(), p1.clone()], normals: None });
    }
    let inst = InstanceDesc {
        name: "ocean".into(),
        geometry: GeometryRef::Mesh(0),
        transforms: vec![glam::Mat4::IDENTITY],
        times: vec![0.0],
        material: 0,
        id: 0,
        visible_to_camera: true,
        casts_shadows: true,
        primvar_row: None,
        index: None,
    };
    let accel = Accel::build(&[std::sync::Arc::new(mesh)], &[], &[inst], (0.0, if motion.is_some() { 1.0 } else { 0.0 }));
    let st = &accel.stats;
    print!(
        "{{\"tide\": true, \"triangles\": {ntri}, \"motion_amplitude\": {}, \"build_s\": {:.4}, \"bytes\": {}, \"bytes_per_triangle\": {:.1}",
        motion.unwrap_or(0.0),
        st.seconds,
        st.bytes,
        st.bytes as f64 / ntri as f64
    );
    let mut ok = true;
    for kind in ["incoherent", "coherent"] {
        let o = read_vec3s(&dir.join(format!("rays_{kind}_o.npy")));
        let d = read_vec3s(&dir.join(format!("rays_{kind}_d.npy")));
        // TIDE_BENCH_RAYS takes a prefix of each set (for instruction-counting runs)
        let n = std::env::var("TIDE_BENCH_RAYS").ok().map_or(o.len(), |s| s.parse::<usize>().expect("TIDE_BENCH_RAYS").min(o.len()));
        let mut first: Option<Vec<Answer>> = None;
        for &t in &threads {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
            let mut out = vec![(0u32, 0u32); n];
            pool.install(|| {
                trace(&accel, &o[..n / 10], &d[..n / 10], motion.is_some(), &mut out[..n / 10]); // warm-up
                // best of `repeats`: other work on a shared machine only ever adds time
                let mut s = f64::INFINITY;
                let mut cpu = f64::INFINITY;
                for _ in 0..repeats {
                    let (start, c0) = (Instant::now(), thread_cpu_seconds());
                    trace(&accel, &o, &d, motion.is_some(), &mut out);
                    s = s.min(start.elapsed().as_secs_f64());
                    cpu = cpu.min(thread_cpu_seconds() - c0);
                }
                if t == 1 {
                    // on one thread the whole pass runs on this worker: its CPU time leaves out
                    // time the machine gave to other processes
                    print!(", \"{kind}_t1_cpu_mrays_s\": {:.3}", n as f64 / cpu / 1e6);
                }
                let hits = out.iter().filter(|a| a.1 != u32::MAX).count();
                print!(
                    ", \"{kind}_t{t}_s\": {s:.4}, \"{kind}_t{t}_mrays_s\": {:.3}, \"{kind}_t{t}_hit_fraction\": {:.6}",
                    n as f64 / s / 1e6,
                    hits as f64 / n as f64
                );
            });
            match &first {
                None => first = Some(out),
                Some(f) => {
                    if *f != out {
                        eprintln!("{kind}: hits differ between {} and {t} threads", threads[0]);
                        ok = false;
                    }
                }
            }
        }
        // Strided subset against brute force: same triangle, or the same distance (shared edges).
        let out = first.unwrap();
        let mut bad = 0;
        for k in 0..checks {
            let i = k * (n / checks) + 7;
            let want = match &second {
                // the mesh at the ray's time, interpolated as the renderer does
                Some(p1) => {
                    let w = ray_time(i);
                    let at: Vec<Vec3> = positions.iter().zip(p1).map(|(a, b)| a.lerp(*b, w)).collect();
                    brute_force(&at, &indices, o[i], d[i])
                }
                None => brute_force(&positions, &indices, o[i], d[i]),
            };
            let got = out[i];
            let agree = match want {
                None => got.1 == u32::MAX,
                Some((t, p)) => {
                    got.1 != u32::MAX && (got.1 == p || (f32::from_bits(got.0) as f64 - t).abs() <= 1e-5 * t.max(1.0))
                }
            };
            if !agree {
                bad += 1;
                eprintln!("{kind} ray {i}: tide {:?} brute force {want:?}", (f32::from_bits(got.0), got.1));
            }
        }
        print!(", \"{kind}_brute_force_checked\": {checks}, \"{kind}_brute_force_mismatches\": {bad}");
        ok &= bad == 0;
    }
    println!(", \"repeats\": {repeats}, \"threads\": \"{}\"}}", threads.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(","));
    if !ok {
        std::process::exit(1);
    }
}
