//! Generates the Jakob–Hanika coefficient tables `core/data/rgb2spec_{rec709,acescg}.bin`
//! with tide-core's own Gauss–Newton fit (format in `core/data/README.md`).
//!
//! `cargo run --release -p tide-core --example gen_rgb2spec [-- RES [OUT_DIR]]`
//! (RES defaults to 32, OUT_DIR to `core/data`).

use std::path::PathBuf;
use tide_core::scene::ColorSpace;
use tide_core::spectrum::rgb2spec::Rgb2SpecTable;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let res = match args.get(1).map(|s| s.parse::<usize>()) {
        None => 32,
        Some(Ok(r)) if (2..=256).contains(&r) => r,
        Some(_) => {
            eprintln!("gen_rgb2spec: RES must be an integer in 2..=256, got {:?}", args[1]);
            std::process::exit(2);
        }
    };
    let dir = args.get(2).map(PathBuf::from).unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data"));
    for (cs, name) in [(ColorSpace::LinearRec709, "rgb2spec_rec709.bin"), (ColorSpace::AcesCg, "rgb2spec_acescg.bin")] {
        let t0 = std::time::Instant::now();
        let table = match Rgb2SpecTable::build(cs, res) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("gen_rgb2spec: {e}");
                std::process::exit(2);
            }
        };
        let path = dir.join(name);
        if let Err(e) = std::fs::write(&path, table.to_bytes()) {
            eprintln!("gen_rgb2spec: cannot write {}: {e}", path.display());
            std::process::exit(1);
        }
        let big = table.coeffs.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
        println!(
            "{}: {res}³×3 entries in {:.1} s (largest |coefficient| {big:.1})",
            path.display(),
            t0.elapsed().as_secs_f64()
        );
    }
}
