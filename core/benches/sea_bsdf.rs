//! Cost of the sea-surface BSDF's `f` and `sample_f` with and without its multiple-scattering
//! compensation, and the one-time cost of the albedo-table nodes a new lobe needs.
//!
//!     cargo bench -p tide-core --bench sea_bsdf
//!
//! The uncompensated lobe is the same sea at a relative IOR outside the compensated range
//! (1.2): the single-scattering work does not depend on η. Directions are fixed pseudo-random
//! sets (1024 pairs), wind 10 m/s; each figure is ns per call, the best of 5 passes. Prints one
//! JSON line.

mod common;
use common::Rng;
use glam::{Vec2, Vec3};
use std::hint::black_box;
use std::time::Instant;
use tide_core::bsdf::{Bsdf, TransportMode};

fn best_ns(calls: usize, mut pass: impl FnMut() -> f32) -> f64 {
    (0..5)
        .map(|_| {
            let t = Instant::now();
            black_box(pass());
            t.elapsed().as_secs_f64() * 1e9 / calls as f64
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let t = Instant::now();
    let comp = Bsdf::sea(1.333, 10.0, 0.4).expect("sea");
    let first_use = t.elapsed().as_secs_f64();
    let plain = Bsdf::sea(1.2, 10.0, 0.4).expect("sea");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let n = 1024;
    let pairs: Vec<(Vec3, Vec3)> = (0..n).map(|_| (rng.dir(), rng.dir())).collect();
    let us: Vec<(f32, Vec2)> = (0..n).map(|_| (rng.next(), Vec2::new(rng.next(), rng.next()))).collect();
    let reps = 200;
    let eval = |b: &Bsdf| {
        best_ns(n * reps, || {
            let mut acc = 0.0;
            for _ in 0..reps {
                for &(wo, wi) in &pairs {
                    acc += b.f(wo, wi, TransportMode::Radiance)[0] + b.pdf(wo, wi, TransportMode::Radiance);
                }
            }
            acc
        })
    };
    let sample = |b: &Bsdf| {
        best_ns(n * reps, || {
            let mut acc = 0.0;
            for _ in 0..reps {
                for (&(wo, _), &(uc, u)) in pairs.iter().zip(&us) {
                    if let Some(s) = b.sample_f(wo, uc, u, TransportMode::Radiance) {
                        acc += s.pdf;
                    }
                }
            }
            acc
        })
    };
    let construct = |eta: f32| {
        best_ns(n * reps, || {
            let mut acc = 0.0;
            for i in 0..n * reps {
                acc += Bsdf::sea(eta, 10.0 + (i % 7) as f32 * 1e-3, 0.4).map_or(0.0, |b| b.flags() as f32);
            }
            acc
        })
    };
    println!(
        "{{\"first_use_s\": {first_use:.3}, \"f_plus_pdf_ns\": [{:.1}, {:.1}], \"sample_f_ns\": [{:.1}, {:.1}], \"new_ns\": [{:.1}, {:.1}], \"order\": \"[single scattering, compensated]\"}}",
        eval(&plain),
        eval(&comp),
        sample(&plain),
        sample(&comp),
        construct(1.2),
        construct(1.333)
    );
}
