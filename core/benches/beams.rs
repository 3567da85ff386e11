//! Equal-time error of thinned photon beams: the caustics integrator on god rays seen from under
//! a wavy surface in scattering water (the caustics tests' `underwater` scene, an 8° sun), at
//! several image widths (height half the width) and shares of the beams kept.
//!
//!     cargo bench -p tide-core --bench beams [-- WIDTHS SHARES SPP ROUNDS]
//!
//! (defaults `256,512 1,0.5,0.25,0.125,0.0625,t8 4 2`; a share of 1 keeps every beam, `tN` the
//! share the probe measures for N beams per query (`CausticsConfig::beams_per_query`), `default`
//! what `CausticsConfig::default()` keeps.) Thinning keeps the expected image,
//! so the error of a render against its expectation is its variance: for each width and share,
//! two renders of SPP samples per pixel with different seeds, `ROUNDS` times, give the relative
//! MSE per render as the mean over pixels × RGB of (a − b)² / 2 / (r² + 10⁻²), r the mean of all
//! the renders at that width (the shared bench's `metrics.py` definition). `time × relMSE` is the
//! inverse of the efficiency: lower is better at equal time. Two threads; prints a table.

#[path = "../tests/common.rs"]
mod common;

use common::*;
use std::time::Instant;
use tide_core::render::IntegratorKind;
use tide_core::Aov;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let list = |i: usize, d: &str| args.get(i).map_or(d, |s| s.as_str()).split(',').map(str::to_string).collect::<Vec<_>>();
    let widths: Vec<u32> = list(0, "256,512").iter().map(|s| s.parse().expect("a width")).collect();
    let shares = list(1, "1,0.5,0.25,0.125,0.0625,t8");
    let spp: u32 = args.get(2).map_or(4, |s| s.parse().expect("samples per pixel"));
    let rounds: u64 = args.get(3).map_or(2, |s| s.parse().expect("rounds"));
    let scene = underwater(8.0);
    println!("| width | share | time per render (s) | relMSE | time × relMSE | vs share 1 |");
    println!("|---|---|---|---|---|---|");
    for &w in &widths {
        let h = w / 2;
        let pixels = (w * h) as u64;
        let mut rows = Vec::new();
        let mut all = vec![0f64; (w * h * 3) as usize];
        let mut count = 0.0;
        for share in &shares {
            // a fixed share f (1: every beam), or a target of beams per query
            let (f, target): (f32, Option<f32>) = match share.strip_prefix('t') {
                _ if share == "default" => (1.0, None),
                Some(t) => (1.0, Some(t.parse().expect("beams per query"))),
                None => (share.parse().expect("a share"), Some(f32::INFINITY)),
            };
            let mut kept = Vec::new();
            let mut time = 0.0;
            let mut pairs = Vec::new();
            for round in 0..rounds {
                let mut pair = Vec::new();
                for seed in [2 * round + 1, 2 * round + 2] {
                    let mut s = settings(w, h, spp);
                    s.integrator = IntegratorKind::Caustics;
                    s.threads = 2;
                    s.seed = seed;
                    if let Some(t) = target {
                        // a share f of the beams is kept above f² × pixels
                        s.caustics.beam_thinning_pixels = if f >= 1.0 { f32::INFINITY } else { f * f * pixels as f32 };
                        s.caustics.beams_per_query = t;
                    }
                    let t = Instant::now();
                    let r = render_progressive(&scene, s);
                    time += t.elapsed().as_secs_f64();
                    kept.push(r.stats().caustics.map_or(1.0, |c| c.beam_share));
                    let px: Vec<f64> = r.aov_pixels(Aov::Color).chunks_exact(4).flat_map(|p| p[..3].iter().map(|&v| v as f64)).collect();
                    for (a, v) in all.iter_mut().zip(&px) {
                        *a += v;
                    }
                    count += 1.0;
                    pair.push(px);
                }
                pairs.push(pair);
            }
            // the default and the probe's rule report the share the probe kept
            let f = if target == Some(f32::INFINITY) { f } else { kept.iter().sum::<f32>() / kept.len() as f32 };
            rows.push((share.clone(), f, time / (2 * rounds) as f64, pairs));
        }
        let reference: Vec<f64> = all.iter().map(|a| a / count).collect();
        let mut base = None;
        for (share, f, time, pairs) in rows {
            let rel = pairs.iter().map(|p| p[0].iter().zip(&p[1]).zip(&reference).map(|((a, b), r)| (a - b).powi(2) / 2.0 / (r * r + 1e-2)).sum::<f64>() / reference.len() as f64).sum::<f64>() / pairs.len() as f64;
            let cost = time * rel;
            let b = *base.get_or_insert(cost);
            let name = if share == "default" || share.starts_with('t') { format!("{share} ({f:.3})") } else { share };
            println!("| {w}×{h} | {name} | {time:.2} | {rel:.4} | {cost:.4} | {:.2} |", cost / b);
        }
    }
}
