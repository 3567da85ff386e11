//! Tests of the wet film ([`super::super::wet`]): χ² of its sampler, consistency, reciprocity,
//! energy balance, a brute-force random walk through the film, and water compliance.

use super::*;
use crate::bsdf::fresnel_dielectric;
use crate::bsdf::wet::{compliance_boost, film_reflectances};

const WATER: f32 = 1.333;

fn wet_lambert(a: f32, amount: f32, eta: f32) -> Bsdf {
    let l = Bsdf::lambert(grey(a)).unwrap();
    Bsdf::wet(l, l, amount, eta).unwrap()
}

fn wet_preview(p: PreviewParams, amount: f32, eta: f32) -> Bsdf {
    let dry = Bsdf::preview(p).unwrap();
    let covered = Bsdf::preview(PreviewParams { outside_ior: WATER, ..p }).unwrap();
    Bsdf::wet(dry, covered, amount, eta).unwrap()
}

/// The configurations of the χ² and consistency tests (6 of them, 3 ωo each).
fn configs() -> Vec<(&'static str, Bsdf)> {
    let base = preview_params();
    vec![
        ("wet lambert", wet_lambert(0.5, 1.0, WATER)),
        ("partly wet lambert", wet_lambert(0.8, 0.6, WATER)),
        ("wet preview", wet_preview(base, 1.0, WATER)),
        ("wet preview, delta specular and coat", wet_preview(PreviewParams { roughness: 0.0, clearcoat: 1.0, clearcoat_roughness: 0.0, ..base }, 0.7, WATER)),
        ("wet rough conductor", Bsdf::wet(conductor(0.4), conductor(0.4), 0.7, 1.6).unwrap()),
        ("index-matched film", wet_preview(PreviewParams { roughness: 0.3, ..base }, 1.0, 1.0)),
    ]
}

#[test]
fn chi2_wet_film() {
    for (name, b) in configs() {
        for wo in [dir(5.0, 0.0), dir(70.0, 30.0), dir(135.0, 10.0)] {
            check_chi2(name, &b, wo, TransportMode::Radiance);
            check_consistency(name, &b, wo, TransportMode::Radiance);
        }
    }
}

#[test]
fn wet_film_is_reciprocal() {
    let mut rng = TestRng::new(5);
    for (name, b) in configs() {
        for _ in 0..500 {
            let wo = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let mut wi = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            wi.z = wi.z.abs().copysign(wo.z);
            let (a, c) = (b.f(wo, wi, TransportMode::Radiance), b.f(wi, wo, TransportMode::Radiance));
            for i in 0..4 {
                assert!((a[i] - c[i]).abs() <= 1e-4 * a[i].abs().max(1e-3), "{name}: {a:?} vs {c:?}");
            }
        }
    }
}

/// A white Lambertian base under a film reflects everything: what the film's underside sends
/// back is scattered again until it leaves. Exact up to the r_e table (≈1e-5).
#[test]
fn furnace_wet_white_lambert_is_one() {
    for (amount, eta) in [(1.0, WATER), (0.4, WATER), (1.0, 2.2)] {
        let b = wet_lambert(1.0, amount, eta);
        for t in FURNACE_THETAS {
            let (m, s) = furnace(&b, dir(t, 0.0), TransportMode::Radiance, 40_000, false);
            assert!((m - 1.0).abs() < 3.0 * s + 1e-3, "amount {amount} η {eta} θ {t}: {m} ± {s}");
        }
    }
}

/// Films over glossy bases drop the glossy light the underside reflects back: never more than
/// the dry surface's energy budget.
#[test]
fn furnace_wet_preview_never_creates_energy() {
    let white = grey(1.0);
    let base = PreviewParams { diffuse: white, base_for_metal: white, ..preview_params() };
    for p in [base, PreviewParams { roughness: 0.0, ..base }, PreviewParams { metallic: 1.0, roughness: 0.3, ..base }, PreviewParams { clearcoat: 1.0, clearcoat_roughness: 0.2, ..base }] {
        let b = wet_preview(p, 1.0, WATER);
        for t in FURNACE_THETAS {
            let (m, s) = furnace(&b, dir(t, 0.0), TransportMode::Radiance, 20_000, false);
            assert!(m <= 1.0 + 3.0 * s + 5e-3, "{p:?} θ {t}: {m} ± {s}");
            assert!(m > 0.6, "{p:?} θ {t}: {m}");
        }
    }
}

/// Brute force: photons arriving from ωo walk through a smooth film over a Lambertian floor
/// (Fresnel choices at every crossing, total internal reflection, absorption at the floor)
/// and the distribution of their exit cosines matches ∫ f(ωo, ωi) μi dωi over cosine bins,
/// mirror reflection included. This checks the closed form (1/η², r_i, the series), not
/// only its sampling.
#[test]
fn wet_lambert_matches_a_random_walk_through_the_film() {
    const BINS: usize = 5;
    let bin = |mu: f32| ((mu * BINS as f32) as usize).min(BINS - 1);
    for (a, eta, theta) in [(0.5f32, WATER, 30.0f32), (0.3, 1.6, 70.0), (0.8, WATER, 85.0)] {
        let wo = dir(theta, 0.0);
        let b = wet_lambert(a, 1.0, eta);
        // the closed form, integrated over μi per bin (f depends on μi only for a Lambert base)
        let mut expect = [0.0f64; BINS];
        let n = 20_000;
        for k in 0..n {
            let mu = (k as f32 + 0.5) / n as f32;
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let f = b.f(wo, wi, TransportMode::Radiance).average() as f64;
            expect[bin(mu)] += 2.0 * std::f64::consts::PI * f * mu as f64 / n as f64;
        }
        expect[bin(wo.z)] += fresnel_dielectric(wo.z, eta) as f64;
        // the walk
        let photons = 400_000;
        let mut count = [0usize; BINS];
        let mut rng = TestRng::new(77);
        for _ in 0..photons {
            if rng.next_f32() < fresnel_dielectric(wo.z, eta) {
                count[bin(wo.z)] += 1;
                continue;
            }
            loop {
                if rng.next_f32() >= a {
                    break; // absorbed by the floor
                }
                let mu_in = rng.next_f32().sqrt(); // Lambertian: cosine-distributed
                if rng.next_f32() < fresnel_dielectric(mu_in, 1.0 / eta) {
                    continue; // back down to the floor (total internal reflection included)
                }
                let mu_out = (1.0 - (1.0 - mu_in * mu_in) * eta * eta).max(0.0).sqrt();
                count[bin(mu_out)] += 1;
                break;
            }
        }
        for k in 0..BINS {
            let p = count[k] as f64 / photons as f64;
            let sigma = (p * (1.0 - p) / photons as f64).sqrt();
            assert!((p - expect[k]).abs() < 4.0 * sigma + 2e-4, "a {a} η {eta} θ {theta} bin {k}: walk {p} vs closed form {}", expect[k]);
        }
        // and the film darkens: less diffuse light leaves than from the dry floor
        let diffuse: f64 = expect.iter().sum::<f64>() - fresnel_dielectric(wo.z, eta) as f64;
        assert!(diffuse < a as f64 * 0.95, "a {a}: {diffuse}");
    }
}

#[test]
fn an_index_matched_film_changes_nothing() {
    let dry = Bsdf::preview(PreviewParams { roughness: 0.4, ..preview_params() }).unwrap();
    let b = Bsdf::wet(dry, dry, 1.0, 1.0).unwrap();
    let mut rng = TestRng::new(9);
    for _ in 0..200 {
        let wo = math::sample_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let wi = math::sample_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let (x, y) = (b.f(wo, wi, TransportMode::Radiance), dry.f(wo, wi, TransportMode::Radiance));
        for i in 0..4 {
            assert!((x[i] - y[i]).abs() <= 1e-5 * y[i].max(1.0), "{x:?} vs {y:?}");
        }
    }
}

#[test]
fn film_reflectances_obey_etendue() {
    for eta in [1.1f32, WATER, 1.5, 2.9, 3.5] {
        let (r_e, r_i) = film_reflectances(eta);
        // brute force: 2∫F μ dμ by a fine midpoint rule in μ
        let n = 200_000;
        let brute: f64 = (0..n).map(|k| {
            let mu = (k as f64 + 0.5) / n as f64;
            2.0 * fresnel_dielectric(mu as f32, eta) as f64 * mu / n as f64
        }).sum();
        assert!((r_e as f64 - brute).abs() < 2e-5, "η {eta}: {r_e} vs {brute}");
        let brute_i: f64 = (0..n).map(|k| {
            let mu = (k as f64 + 0.5) / n as f64;
            2.0 * fresnel_dielectric(mu as f32, 1.0 / eta) as f64 * mu / n as f64
        }).sum();
        assert!((r_i as f64 - brute_i).abs() < 1e-4, "η {eta}: {r_i} vs {brute_i}");
    }
    assert_eq!(film_reflectances(1.0), (0.0, 0.0));
}

#[test]
fn water_compliance_brightens_under_water_only() {
    let d = SampledSpectrum([0.0, 0.2, 0.5, 1.0]);
    // in air: unchanged, bit for bit
    assert_eq!(compliance_boost(d, WATER, 1.0), d);
    // under water: the film is index-matched, so the boost undoes the darkening of a film in
    // air, (1 − r_e) / (η² (1 − a r_i))
    let b = compliance_boost(d, WATER, WATER);
    let (r_e, r_i) = film_reflectances(WATER);
    for i in 0..4 {
        let a = d[i];
        let expect = (a * WATER * WATER * (1.0 - a * r_i) / (1.0 - r_e)).min(1.0);
        assert!((b[i] - expect).abs() < 1e-6, "{a}: {} vs {expect}", b[i]);
        assert!(b[i] >= a && b[i] <= 1.0);
    }
    assert!(b[2] > 0.6, "mid grey brightens noticeably: {}", b[2]);
    assert_eq!(b[3], 1.0);
}
