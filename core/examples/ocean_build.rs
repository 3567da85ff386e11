//! Time to build a large ocean mesh (extent 2000 m, resolution 512, the camera 2 m above the
//! water with 1 mrad pixels), best of three.
//!
//! `cargo run --release -p tide-core --example ocean_build`

fn main() {
    let p = tide_core::ocean::OceanParams { extent: 2000.0, resolution: 512, ..Default::default() };
    let view = tide_core::ocean::OceanView { position: glam::Vec3::new(3.0, 2.0, 3.0), pixel_angle: 1e-3, pixel_width: 0.0 };
    let mut best = f64::INFINITY;
    let mut tris = 0;
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let m = tide_core::ocean::ocean_mesh_seen(&p, 1.0, &view).expect("ocean");
        best = best.min(t.elapsed().as_secs_f64());
        tris = m.indices.len() / 3;
    }
    println!("{tris} triangles in {best:.3} s");
}
