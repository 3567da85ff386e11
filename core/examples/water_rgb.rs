//! The constant RGB medium closest to a natural water: σa and σs of the bio-optical model
//! averaged over a water column of depth H and over the wavelength band of each RGB channel
//! (R 600–700 nm, G 500–600 nm, B 400–500 nm). `bench/water_models.py --matched-rgb` uses it so
//! that the constant medium it compares against scatters and absorbs about as much as the
//! spectral one: the cost measured is then that of the model, not of a different light
//! transport (more scattering events per path).
//!
//! ```text
//! cargo run --release -p tide-core --example water_rgb -- --depth H [--jerlov TYPE]
//!     [--chlorophyll C] [--cdom C] [--spm C] [--profile DEPTH,WIDTH,PEAK] [--salinity S]
//! ```
//!
//! Prints `absorption R G B` and `scattering R G B` (1/m).

use tide_core::scene::{DepthProfileDesc, JerlovDesc, WaterIopDesc};
use tide_core::water::{bio_optical_from_desc, JerlovSource, JerlovType};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut desc = WaterIopDesc { salinity: 35.0, ..WaterIopDesc::default() };
    let mut depth = 0.0f32;
    let num = |s: &str| s.parse::<f32>().unwrap_or_else(|_| fail(&format!("not a number: {s}")));
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).map(String::as_str).unwrap_or_else(|| fail(&format!("{} needs a value", args[i])));
        match args[i].as_str() {
            "--depth" => depth = num(value),
            "--jerlov" => {
                let water_type = JerlovType::parse(value).unwrap_or_else(|e| fail(&e.to_string()));
                let source = if JerlovSource::Williamson2022.has_type(water_type) { JerlovSource::Williamson2022 } else { JerlovSource::Solonenko2015 };
                desc.jerlov = Some(JerlovDesc { water_type, source });
            }
            "--chlorophyll" => desc.chlorophyll = num(value),
            "--cdom" => desc.cdom = num(value),
            "--spm" => desc.spm = num(value),
            "--salinity" => desc.salinity = num(value),
            "--profile" => {
                let v: Vec<f32> = value.split(',').map(num).collect();
                if v.len() != 3 {
                    fail("--profile takes DEPTH,WIDTH,PEAK");
                }
                desc.profile = Some(DepthProfileDesc { depth: v[0], width: v[1], peak: v[2] });
            }
            other => fail(&format!("unknown argument {other}")),
        }
        i += 2;
    }
    if !(depth > 0.0) {
        fail("--depth H (> 0, m) is required");
    }
    let water = bio_optical_from_desc(&desc).unwrap_or_else(|e| fail(&e.to_string()));
    // midpoint rule: 400 depths, whole nanometres across each band
    let nz = 400;
    let bands = [(600, 700), (500, 600), (400, 500)];
    let mut out = [[0.0f64; 3]; 2];
    for (c, &(l0, l1)) in bands.iter().enumerate() {
        let mut n = 0usize;
        for k in 0..nz {
            let z = depth * (k as f32 + 0.5) / nz as f32;
            for l in l0..l1 {
                let (a, s) = water.coefficients_at(z, l as f32 + 0.5);
                out[0][c] += a as f64;
                out[1][c] += s as f64;
                n += 1;
            }
        }
        out[0][c] /= n as f64;
        out[1][c] /= n as f64;
    }
    println!("absorption {:.6} {:.6} {:.6}", out[0][0], out[0][1], out[0][2]);
    println!("scattering {:.6} {:.6} {:.6}", out[1][0], out[1][1], out[1][2]);
}

fn fail(msg: &str) -> ! {
    eprintln!("water_rgb: {msg}");
    std::process::exit(2);
}
