//! Tests of the photon map and the guiding atlas: brute-force agreement, unbiasedness of the
//! estimators against analytic values, leak rejection, thread-count determinism, χ² of the
//! atlas's sampling against its pdf, and concentration of the learned table on the casters.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::atlas::*;
use super::photon_map::*;
use crate::math::{sample_uniform_sphere, Frame};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN};
use crate::testing::chi2::{chi2_sphere, Chi2Config};
use crate::testing::chi2::TestRng;

fn rng_dir(rng: &mut TestRng) -> Vec3 {
    sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()))
}

fn flat_photon(pos: Vec3, wi: Vec3, n: Vec3, power: f32, rng: &mut TestRng, id: u32) -> Photon {
    let lambda = SampledWavelengths::sample_uniform(rng.next_f32());
    Photon::new(pos, wi, n, SampledSpectrum::splat(power), &lambda, id).unwrap()
}

fn random_photons(n: usize, seed: u64) -> Vec<Photon> {
    let mut rng = TestRng::new(seed);
    (0..n)
        .map(|i| {
            let mut p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            match i % 10 {
                // on cell boundaries of the 0.05 grid
                0 => p = (p * 20.0).round() / 20.0,
                // a dense cluster
                1 | 2 => p = Vec3::splat(0.5) + (p - 0.5) * 0.02,
                _ => {}
            }
            if i == 7 {
                p = Vec3::new(1e6, -3e7, 2.0);
            }
            let power = rng.next_f32() * rng.next_f32() * 4.0;
            flat_photon(p, rng_dir(&mut rng), rng_dir(&mut rng), power, &mut rng, i as u32)
        })
        .collect()
}

fn query(p: Vec3, n: Vec3, r: f32, check: NormalCheck) -> Query {
    Query { position: p, normal: n, radius: r, normal_check: check }
}

#[test]
fn photon_is_48_bytes_and_round_trips() {
    assert_eq!(BYTES_PER_PHOTON, 48);
    let mut rng = TestRng::new(3);
    for _ in 0..1000 {
        let wi = rng_dir(&mut rng);
        let n = rng_dir(&mut rng);
        let lambda = SampledWavelengths::sample_uniform(rng.next_f32());
        let p = Photon::new(Vec3::ONE, wi * 3.0, n, SampledSpectrum::splat(1.0), &lambda, 0).unwrap();
        // 16-bit octahedral coordinates: worst-case angular error ≈ 2·(2/65535) rad ≈ 6e-5
        assert!(p.wi().cross(wi).length() < 1e-4 && p.wi().dot(wi) > 0.0);
        let nf = if n.dot(wi) < 0.0 { -n } else { n };
        assert!(p.normal().cross(nf).length() < 1e-4 && p.normal().dot(nf) > 0.0, "normal is stored on the photon's side");
        for (a, b) in p.lambda().iter().zip(lambda.lambda) {
            // half a quantisation step of (830 − 360)/65535 nm
            assert!((a - b).abs() <= 0.0037, "{a} {b}");
        }
    }
}

#[test]
fn radius_queries_equal_brute_force() {
    let photons = random_photons(10_000, 11);
    let map = PhotonMap::build(photons, 0.05).unwrap();
    let mut rng = TestRng::new(5);
    let checks = [NormalCheck::None, NormalCheck::SameSide { cos_min: 0.5 }, NormalCheck::EitherSide { cos_min: 0.3 }];
    let mut total_found = 0usize;
    for qi in 0..120 {
        let mut p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        if qi % 3 == 0 {
            p = Vec3::splat(0.5) + (p - 0.5) * 0.03;
        }
        if qi % 17 == 0 {
            p = (p * 20.0).round() / 20.0;
        }
        let n = rng_dir(&mut rng);
        for r in [0.013, 0.05, 0.11, 3.0] {
            for check in checks {
                let q = query(p, n, r, check);
                let mut got = Vec::new();
                map.for_each_in_radius(&q, |ph, k| {
                    assert_eq!(k, 1.0 / (std::f32::consts::PI * r * r));
                    got.push(ph.cell)
                });
                let mut want: Vec<u32> = map
                    .photons()
                    .iter()
                    .filter(|ph| {
                        ph.position.distance_squared(p) <= r * r
                            && match check {
                                NormalCheck::None => true,
                                NormalCheck::SameSide { cos_min } => n.dot(ph.normal()) >= cos_min,
                                NormalCheck::EitherSide { cos_min } => n.dot(ph.normal()).abs() >= cos_min,
                            }
                    })
                    .map(|ph| ph.cell)
                    .collect();
                got.sort_unstable();
                want.sort_unstable();
                assert_eq!(got, want, "query {qi} r {r} {check:?}");
                total_found += got.len();
            }
        }
    }
    assert!(total_found > 20_000, "the queries must find photons to compare: {total_found}");
}

/// Photons on the plane z = 0 with widely varying energies.
fn plane_map(n: usize, seed: u64) -> PhotonMap {
    let mut rng = TestRng::new(seed);
    let photons = (0..n)
        .map(|i| {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), 0.0);
            let e = (rng.next_f32() * 4.0).exp();
            let lambda = SampledWavelengths::sample_uniform(rng.next_f32());
            let power = SampledSpectrum::from_fn(|k| e * (0.5 + (lambda.lambda[k] - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN)));
            Photon::new(p, Vec3::new(0.2, 0.1, 1.0), Vec3::Z, power, &lambda, i as u32).unwrap()
        })
        .collect();
    PhotonMap::build(photons, 0.1).unwrap()
}

#[test]
fn single_photon_estimator_mean_is_the_full_kernel_estimate() {
    let kernel = SpectralKernel::default();
    let (mut pooled_diff, mut pooled_var) = ([0f64; 4], [0f64; 4]);
    let mut comparisons = 0;
    for seed in 0..8u64 {
        let map = plane_map(3000, 100 + seed);
        let mut rng = TestRng::new(seed);
        for _ in 0..4 {
            let p = Vec3::new(0.15 + 0.7 * rng.next_f32(), 0.15 + 0.7 * rng.next_f32(), 0.0);
            let q = query(p, Vec3::Z, 0.1, NormalCheck::SameSide { cos_min: 0.9 });
            let lookup = kernel.at(&SampledWavelengths::sample_uniform(rng.next_f32()));
            let full = map.estimate(&q, &lookup);
            let m = 4000;
            let (mut s1, mut s2) = ([0f64; 4], [0f64; 4]);
            for _ in 0..m {
                let e = map.estimate_one(&q, &lookup, rng.next_f32());
                for i in 0..4 {
                    s1[i] += e.0[i] as f64;
                    s2[i] += (e.0[i] as f64).powi(2);
                }
            }
            for i in 0..4 {
                let mean = s1[i] / m as f64;
                let var = (s2[i] / m as f64 - mean * mean).max(0.0) / m as f64;
                assert!(var > 0.0, "one photon out of ~90 cannot be a constant estimate");
                let z = (mean - full.0[i] as f64) / var.sqrt();
                // 128 comparisons: |z| < 4 keeps the family-wise false alarm under 1%
                assert!(z.abs() < 4.0, "seed {seed}: mean {mean} vs full {} (z = {z})", full.0[i]);
                pooled_diff[i] += mean - full.0[i] as f64;
                pooled_var[i] += var;
                comparisons += 1;
            }
        }
    }
    assert_eq!(comparisons, 128);
    for i in 0..4 {
        // the pooled difference over 32 lookups per wavelength slot: 3σ
        assert!(pooled_diff[i].abs() < 3.0 * pooled_var[i].sqrt(), "pooled z = {}", pooled_diff[i] / pooled_var[i].sqrt());
    }
}

#[test]
fn single_photon_estimator_averaged_over_stratified_numbers_is_exact() {
    // With u on a regular grid of M strata the average of the one-photon estimate is the
    // selection sum Σ p_i · e_i up to the strata that straddle one of the n probability
    // boundaries: |error| ≤ n · max|e| / M.
    let kernel = SpectralKernel::default();
    let map = plane_map(3000, 5);
    let q = query(Vec3::new(0.4, 0.6, 0.0), Vec3::Z, 0.1, NormalCheck::SameSide { cos_min: 0.9 });
    let lookup = kernel.at(&SampledWavelengths::sample_uniform(0.37));
    let full = map.estimate(&q, &lookup);
    let mut n = 0;
    map.for_each_in_radius(&q, |_, _| n += 1);
    let m = 100_000;
    let (mut sum, mut max) = ([0f64; 4], [0f64; 4]);
    for j in 0..m {
        let e = map.estimate_one(&q, &lookup, (j as f32 + 0.5) / m as f32);
        for i in 0..4 {
            sum[i] += e.0[i] as f64;
            max[i] = max[i].max(e.0[i] as f64);
        }
    }
    assert!(n > 50, "{n} photons in reach");
    for i in 0..4 {
        let err = (sum[i] / m as f64 - full.0[i] as f64).abs();
        let bound = n as f64 * max[i] / m as f64;
        assert!(err <= bound, "slot {i}: error {err} above the stratification bound {bound}");
        assert!(bound < 0.05 * full.0[i] as f64, "the bound is tight enough to mean something");
    }
}

#[test]
fn density_of_uniform_photons_on_a_plane_is_recovered() {
    // N photons of flux Φ/N (flat spectrum) uniform on the unit square: irradiance Φ per m² at
    // every wavelength, the range ends included thanks to the kernel's renormalisation.
    let n = 200_000;
    let phi = 5.0;
    let mut rng = TestRng::new(77);
    let photons: Vec<Photon> = (0..n)
        .map(|i| flat_photon(Vec3::new(rng.next_f32(), rng.next_f32(), 0.0), Vec3::Z, Vec3::Z, phi / n as f32, &mut rng, i))
        .collect();
    let map = PhotonMap::build(photons, 0.05).unwrap();
    let kernel = SpectralKernel::default();
    for lc in [362.0, 600.0, 828.0] {
        let lambda = SampledWavelengths { lambda: [lc; 4], pdf: [1.0; 4] };
        let lookup = kernel.at(&lambda);
        let mut xs = Vec::new();
        // 64 disjoint disks (spacing 0.1 = 2r): independent estimates
        for a in 0..8 {
            for b in 0..8 {
                let p = Vec3::new(0.15 + 0.1 * a as f32, 0.15 + 0.1 * b as f32, 0.0);
                xs.push(map.estimate(&query(p, Vec3::Z, 0.05, NormalCheck::SameSide { cos_min: 0.5 }), &lookup).0[0] as f64);
            }
        }
        let m = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / m;
        let se = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0) / m).sqrt();
        assert!((mean - phi as f64).abs() < 3.0 * se, "λ {lc}: {mean} vs {phi} (σ {se})");
        // about 1570 photons per disk: the estimate's relative error is a few percent, so 3σ is tight
        assert!(se < 0.02 * phi as f64, "σ {se}");
    }
}

#[test]
fn wavelength_kernel_is_unbiased_for_linear_spectra_inside_the_range() {
    // Φ(λ) = a + bλ; away from the range ends the symmetric kernel reproduces it exactly.
    let kernel = SpectralKernel::new(50.0).unwrap();
    let mut rng = TestRng::new(9);
    for lc in [450.0f32, 555.0, 700.0] {
        let lookup = kernel.at(&SampledWavelengths { lambda: [lc; 4], pdf: [1.0; 4] });
        let m = 200_000;
        let (mut s1, mut s2) = (0f64, 0f64);
        for _ in 0..m {
            let lambda = SampledWavelengths::sample_uniform(rng.next_f32());
            let power = SampledSpectrum::from_fn(|k| 0.2 + 0.003 * lambda.lambda[k]);
            let p = Photon::new(Vec3::ZERO, Vec3::Z, Vec3::Z, power, &lambda, 0).unwrap();
            let v = p.spectral_flux(&lookup).0[0] as f64;
            s1 += v;
            s2 += v * v;
        }
        let mean = s1 / m as f64;
        let se = ((s2 / m as f64 - mean * mean) / m as f64).sqrt();
        let want = 0.2 + 0.003 * lc as f64;
        assert!((mean - want).abs() < 3.0 * se, "λ {lc}: {mean} vs {want} (σ {se})");
    }
    // a camera path after dispersion: hero only, its pdf divided by 4, flux kept
    let mut lambda = SampledWavelengths::sample_uniform(0.3);
    lambda.terminate_secondary();
    let p = Photon::new(Vec3::ZERO, Vec3::Z, Vec3::Z, SampledSpectrum::splat(1.0), &lambda, 0).unwrap();
    let f = p.flux();
    assert_eq!(&f[1..], &[0.0; 3]);
    assert!((f[0] - 1.0 / (lambda.pdf[0] * 4.0)).abs() < 1e-3 * f[0]);
}

#[test]
fn normal_check_rejects_photons_from_the_other_side_of_a_thin_wall() {
    // A wall 5 mm thick, much thinner than the 10 cm lookup radius: its lower face (normal −z)
    // is lit from below, its upper face (normal +z) from above. A second case stores photons
    // under a single-sided sheet whose geometric normal is +z on both sides.
    let mut rng = TestRng::new(21);
    let mut photons = Vec::new();
    for i in 0..4000u32 {
        let (x, y) = (rng.next_f32(), rng.next_f32());
        let top = i % 2 == 0;
        let p = Vec3::new(x, y, if top { 0.005 } else { 0.0 });
        let wi = if top { Vec3::new(0.1, 0.0, 1.0) } else { Vec3::new(0.0, 0.2, -1.0) };
        let n = if top || i % 4 == 1 { Vec3::Z } else { -Vec3::Z };
        photons.push(flat_photon(p, wi, n, 1.0, &mut rng, i));
    }
    let map = PhotonMap::build(photons, 0.1).unwrap();
    for j in 0..50 {
        let p = Vec3::new(0.2 + 0.012 * j as f32, 0.5, 0.005);
        let count = |check| {
            let (mut top, mut bottom) = (0, 0);
            map.for_each_in_radius(&query(p, Vec3::Z, 0.1, check), |ph, _| if ph.cell % 2 == 0 { top += 1 } else { bottom += 1 });
            (top, bottom)
        };
        let (top_all, bottom_all) = count(NormalCheck::None);
        assert!(bottom_all > 10, "photons from below are in reach, so the check has work to do");
        let (top, bottom) = count(NormalCheck::SameSide { cos_min: 0.7 });
        assert_eq!(bottom, 0, "leak through the wall at {p}");
        assert_eq!(top, top_all, "photons on the shaded side are all kept");
        // the two-sided check keeps the wrong side, as documented (translucent receivers)
        assert_eq!(count(NormalCheck::EitherSide { cos_min: 0.7 }), (top_all, bottom_all));
    }
}

fn stage() -> (Vec<AtlasLight>, Vec<Caster>, Vec<(Vec3, Vec3)>) {
    let lights = vec![
        AtlasLight::Local { center: Vec3::new(0.0, 6.0, 0.0), radius: 0.0, power: 800.0, emit: None },
        AtlasLight::Distant { to_light: Vec3::new(0.3, 1.0, 0.2).normalize(), irradiance: 3.0, cos_half_angle: 0.99999 },
    ];
    // bounding spheres and the casters' real shapes inside them (axis-aligned boxes)
    let boxes = vec![
        (Vec3::new(-2.0, 1.0, 0.0), Vec3::new(0.9, 0.3, 0.5)),
        (Vec3::new(1.5, 0.5, 1.0), Vec3::new(0.25, 0.5, 0.25)),
        (Vec3::new(0.5, 2.0, -1.5), Vec3::new(0.6, 0.6, 0.1)),
    ];
    let casters = boxes.iter().map(|(c, h)| Caster { center: *c, radius: h.length() }).collect();
    (lights, casters, boxes)
}

fn hit_box(o: Vec3, d: Vec3, c: Vec3, h: Vec3) -> Option<f32> {
    let inv = d.recip();
    let t0 = (c - h - o) * inv;
    let t1 = (c + h - o) * inv;
    let tn = t0.min(t1).max_element();
    let tf = t0.max(t1).min_element();
    (tn <= tf && tf > 0.0).then_some(tn.max(0.0))
}

/// Whether the emission's first hit among the boxes is the pair's caster.
fn reaches_caster(e: &PhotonEmission, caster: usize, boxes: &[(Vec3, Vec3)]) -> bool {
    // start distant-light photons well outside the stage
    let o = if e.measure == EmissionMeasure::Area { e.origin - e.dir * 20.0 } else { e.origin };
    let hits: Vec<Option<f32>> = boxes.iter().map(|(c, h)| hit_box(o, e.dir, *c, *h)).collect();
    match hits[caster] {
        Some(t) => hits.iter().all(|h| h.is_none_or(|u| u >= t)),
        None => false,
    }
}

fn light_point(atlas: &Atlas, s: &AtlasSample) -> Vec3 {
    match atlas.lights()[s.light as usize] {
        AtlasLight::Local { center, .. } => center,
        AtlasLight::Distant { .. } => Vec3::ZERO,
    }
}

/// A pass of `n` photons; the visibility signal is the photon's hit divided by its cell's
/// probability (the Monte Carlo weight the lookup radius would carry), times a float factor
/// whose sums are order-dependent in floating point.
fn train_pass(atlas: &mut Atlas, boxes: &[(Vec3, Vec3)], n: u32, pass: u32) {
    let vis = VisibilityBuffer::new(atlas, 1.0).unwrap();
    (0..n).into_par_iter().for_each(|i| {
        let mut rng = TestRng::new(((pass as u64) << 32) | i as u64);
        let s = atlas.sample([rng.next_f32(), rng.next_f32()]);
        let Some(e) = atlas.emit(&s, light_point(atlas, &s)) else { return };
        if reaches_caster(&e, s.caster as usize, boxes) {
            let cells = atlas.cell_count() as f32;
            let value = (0.7 + 0.3 * rng.next_f32()) / (atlas.cell_probability(s.cell) * cells);
            let kind = if i % 3 == 0 { VisibilityKind::Volume } else { VisibilityKind::Surface };
            vis.record(s.cell, kind, value);
        }
    });
    atlas.end_pass(&vis, n as u64).unwrap();
}

fn trained_atlas(passes: u32) -> (Atlas, Vec<(Vec3, Vec3)>) {
    let (lights, casters, boxes) = stage();
    let cfg = AtlasConfig { width: 48, height: 48, camera: None, defensive: 0.1, disk_refit: false };
    let mut atlas = Atlas::new(&lights, &casters, None, &cfg).unwrap();
    for pass in 0..passes {
        train_pass(&mut atlas, &boxes, 60_000, pass);
    }
    (atlas, boxes)
}

#[test]
fn build_and_learning_are_identical_on_one_and_two_threads() {
    let run = |threads: usize, reverse: bool| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut photons = random_photons(30_000, 4);
            if reverse {
                photons.reverse();
                photons.swap(10, 2000);
            }
            let map = PhotonMap::build(photons, 0.05).unwrap();
            let (atlas, _) = trained_atlas(3);
            (map, atlas.to_image().2, atlas.visibility_image().2)
        })
    };
    let (m1, t1, v1) = run(1, false);
    let (m2, t2, v2) = run(2, true);
    assert!(m1 == m2, "photon maps differ");
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&t1), bits(&t2), "learned tables differ");
    assert_eq!(bits(&v1), bits(&v2), "visibility signals differ");
    assert!(t1.iter().any(|&v| v > 0.0 && v < 0.5), "the table has learned something non-uniform");
}

#[test]
fn atlas_direction_sampling_passes_chi2_against_its_pdf() {
    let (atlas, _) = trained_atlas(3);
    let origin = match atlas.lights()[0] {
        AtlasLight::Local { center, .. } => center,
        _ => unreachable!(),
    };
    let cfg = Chi2Config { theta_res: 16, phi_res: 32, samples: 300_000, quad_res: 32, ..Default::default() };
    let r = chi2_sphere(
        cfg,
        |rng| {
            let s = atlas.sample([rng.next_f32(), rng.next_f32()]);
            (s.light == 0).then(|| atlas.emit(&s, origin).unwrap().dir)
        },
        |d| atlas.pdf_direction(0, origin, d),
    );
    assert!(r.passed(0.01, 2), "{r:?}");
    // the pdf integrates to the probability of picking light 0; midpoint quadrature of a density
    // with cone edges and cell steps is good to a few parts in a thousand at 32² points per cell
    assert!((r.pdf_integral - r.success_rate).abs() < 5e-3, "{r:?}");
    assert!(r.success_rate > 0.05 && r.success_rate < 0.95, "both lights are sampled: {}", r.success_rate);
}

#[test]
fn atlas_position_sampling_passes_chi2_against_its_pdf() {
    // Distant light: disk positions (in the light's perpendicular plane) mapped to the upper
    // hemisphere by the equal-area map ρ² = 1 − z of a disk of radius `big`, so dω = 2 dA / big².
    let (atlas, _) = trained_atlas(3);
    let AtlasLight::Distant { to_light, .. } = atlas.lights()[1] else { unreachable!() };
    let frame = Frame::from_normal(-to_light);
    let big = 5.0f32;
    let cfg = Chi2Config { theta_res: 16, phi_res: 32, samples: 300_000, quad_res: 32, ..Default::default() };
    let r = chi2_sphere(
        cfg,
        |rng| {
            let s = atlas.sample([rng.next_f32(), rng.next_f32()]);
            if s.light != 1 {
                return None;
            }
            let v = frame.to_local(atlas.emit(&s, Vec3::ZERO).unwrap().origin);
            let (a, b) = (v.x / big, v.y / big);
            let rho2 = a * a + b * b;
            assert!(rho2 < 1.0, "the test's disk holds every caster");
            let k = (2.0 - rho2).sqrt();
            Some(Vec3::new(a * k, b * k, 1.0 - rho2))
        },
        |d| {
            if d.z <= 0.0 {
                return 0.0;
            }
            let rho = (1.0 - d.z).max(0.0).sqrt();
            let phi = d.y.atan2(d.x);
            let p = frame.to_world(Vec3::new(big * rho * phi.cos(), big * rho * phi.sin(), 0.0));
            atlas.pdf_position(1, p) * big * big / 2.0
        },
    );
    assert!(r.passed(0.01, 2), "{r:?}");
    assert!((r.pdf_integral - r.success_rate).abs() < 5e-3, "{r:?}");
}

#[test]
fn learned_table_concentrates_on_the_casters() {
    let (atlas, boxes) = trained_atlas(4);
    // a cell is "on the caster" when the emission through its centre reaches it first
    let (w, h) = (atlas.width(), atlas.height());
    let (mut mass_on, mut cells_on, mut cells_used) = (0.0f64, 0usize, 0usize);
    for c in 0..w * h {
        let Some(pair) = atlas.pair_of_cell(c) else { continue };
        cells_used += 1;
        let (col, row) = (c % w, c / w);
        let local = [(col - pair.x) as f32 + 0.5, (row - pair.y) as f32 + 0.5].map(|v| v / pair.size as f32);
        let pair_index = atlas.pairs().iter().position(|p| p == pair).unwrap() as u32;
        let s = AtlasSample { pair: pair_index, light: pair.light, caster: pair.caster, cell: c, local, pdf_local: 1.0 };
        let e = atlas.emit(&s, light_point(&atlas, &s)).unwrap();
        if reaches_caster(&e, pair.caster as usize, &boxes) {
            cells_on += 1;
            mass_on += atlas.cell_probability(c) as f64;
        }
    }
    let uniform = cells_on as f64 / cells_used as f64;
    // After 4 passes the table is t·U + (1−t)·V with t = max(1/5, 0.1) = 0.2. V lives on cells
    // that some photon made it through: all "on" cells plus the outline cells whose centre
    // misses, ~15% of the outline-dominated boxes here. So mass_on ≥ 0.2·uniform + 0.8·0.85.
    assert!(uniform < 0.6, "the boxes must leave room in their bounding cones: {uniform}");
    assert!(mass_on > 0.2 * uniform + 0.8 * 0.85, "mass on casters {mass_on}, uniform share {uniform}");
    let total: f64 = (0..w * h).map(|c| atlas.cell_probability(c) as f64).sum();
    assert!((total - 1.0).abs() < 1e-4, "cell probabilities sum to {total}");
}

#[test]
fn packing_fills_the_table_without_overlap_in_importance_order() {
    let mut rng = TestRng::new(8);
    let lights: Vec<AtlasLight> = (0..5)
        .map(|_| AtlasLight::Local { center: rng_dir(&mut rng) * 10.0, radius: 0.0, power: 10.0 + 1000.0 * rng.next_f32(), emit: None })
        .collect();
    let casters: Vec<Caster> = (0..7).map(|_| Caster { center: rng_dir(&mut rng) * 2.0, radius: 0.1 + rng.next_f32() }).collect();
    let atlas = Atlas::new(&lights, &casters, None, &AtlasConfig { width: 128, height: 96, ..Default::default() }).unwrap();
    let pairs = atlas.pairs();
    assert_eq!(pairs.len(), 35);
    let area: u32 = pairs.iter().map(|p| p.size * p.size).sum();
    let mut owned = vec![0u8; (atlas.width() * atlas.height()) as usize];
    for p in pairs {
        assert!(p.x + p.size <= atlas.width() && p.y + p.size <= atlas.height());
        for r in p.y..p.y + p.size {
            for c in p.x..p.x + p.size {
                owned[(r * atlas.width() + c) as usize] += 1;
            }
        }
    }
    assert!(owned.iter().all(|&o| o <= 1), "squares overlap");
    assert_eq!(owned.iter().filter(|&&o| o == 1).count() as u32, area);
    // greedy square packing of 35 random sizes: the paper reports > 90% on real scenes; the
    // floor() of each side alone costs up to ~2/side of its area
    assert!(atlas.utilization() > 0.7, "utilization {}", atlas.utilization());
    for a in pairs {
        for b in pairs {
            if a.importance > b.importance {
                assert!(a.size >= b.size, "more important pairs get larger squares");
            }
        }
    }
    // the initial table is uniform over used cells: pair probability ∝ area
    let p0: f32 = (0..atlas.cell_count() as u32).filter(|&c| atlas.pair_of_cell(c) == Some(&pairs[0])).map(|c| atlas.cell_probability(c)).sum();
    assert!((p0 - (pairs[0].size * pairs[0].size) as f32 / area as f32).abs() < 1e-4);
}

#[test]
fn first_pass_only_trains_and_the_second_compensates() {
    let (lights, casters, boxes) = stage();
    let mut atlas = Atlas::new(&lights, &casters, None, &AtlasConfig::default()).unwrap();
    assert_eq!(atlas.photon_weight(16), 0.0);
    train_pass(&mut atlas, &boxes, 1000, 0);
    // N₁ = 1000 camera samples, N₂ = 3000
    assert_eq!(atlas.photon_weight(3000), 4000.0 / 3000.0);
    train_pass(&mut atlas, &boxes, 1000, 1);
    assert_eq!(atlas.photon_weight(5000), 1.0);
}

#[test]
fn fixed_point_visibility_sums_exactly_in_any_order() {
    let (lights, casters, _) = stage();
    let atlas = Atlas::new(&lights, &casters, None, &AtlasConfig { width: 8, height: 8, ..Default::default() }).unwrap();
    let mut rng = TestRng::new(1);
    let values: Vec<f32> = (0..10_000).map(|_| rng.next_f32() * 10.0_f32.powf(rng.next_f32() * 6.0 - 3.0)).collect();
    let sum_in = |order: &mut dyn Iterator<Item = f32>| {
        let v = VisibilityBuffer::new(&atlas, 0.5).unwrap();
        order.for_each(|x| v.record(3, VisibilityKind::Surface, x));
        v.value(3, VisibilityKind::Surface)
    };
    let a = sum_in(&mut values.iter().copied());
    let b = sum_in(&mut values.iter().rev().copied());
    assert_eq!(a.to_bits(), b.to_bits());
    let exact: f64 = values.iter().map(|&x| x as f64).sum();
    // each record rounds to 0.5 · 2^-24: the sum is within n · 2^-26 of the exact one
    assert!((a - exact).abs() <= values.len() as f64 * 0.5 * 2f64.powi(-24) * 0.5 + 1e-9, "{a} vs {exact}");
}

#[test]
fn bad_input_returns_errors_naming_the_problem() {
    let lambda = SampledWavelengths::sample_uniform(0.2);
    let one = SampledSpectrum::ONE;
    assert_eq!(Photon::new(Vec3::NAN, Vec3::Z, Vec3::Z, one, &lambda, 0), Err(PhotonError::Position));
    assert_eq!(Photon::new(Vec3::ZERO, Vec3::ZERO, Vec3::Z, one, &lambda, 0), Err(PhotonError::Direction));
    assert_eq!(Photon::new(Vec3::ZERO, Vec3::Z, Vec3::INFINITY, one, &lambda, 0), Err(PhotonError::Normal));
    assert_eq!(Photon::new(Vec3::ZERO, Vec3::Z, Vec3::Z, -one, &lambda, 0), Err(PhotonError::Power));
    let bad_l = SampledWavelengths { lambda: [900.0; 4], pdf: [1.0; 4] };
    assert_eq!(Photon::new(Vec3::ZERO, Vec3::Z, Vec3::Z, one, &bad_l, 0), Err(PhotonError::Wavelength));
    assert!(matches!(PhotonMap::build(vec![], 0.0), Err(PhotonError::CellSize(_))));
    assert!(matches!(PhotonMap::build(vec![], f32::NAN), Err(PhotonError::CellSize(_))));
    let ph = Photon::new(Vec3::ZERO, Vec3::Z, Vec3::Z, one, &lambda, 0).unwrap();
    assert_eq!(PhotonMap::build_bounded(vec![ph; 3], 1.0, 2).unwrap_err(), PhotonError::TooManyPhotons { count: 3, max: 2 });
    assert!(SpectralKernel::new(-1.0).is_err());
    assert!(PhotonError::Wavelength.to_string().contains("wavelength"));
    // queries with bad numbers find nothing and do not panic
    let map = PhotonMap::build(vec![ph], 1.0).unwrap();
    assert!(map.sample_one(&query(Vec3::NAN, Vec3::Z, 1.0, NormalCheck::None), 0.5).is_none());
    assert!(map.sample_one(&query(Vec3::ZERO, Vec3::Z, -1.0, NormalCheck::None), 0.5).is_none());
    assert!(map.sample_one(&query(Vec3::ZERO, Vec3::Z, 1.0, NormalCheck::None), 1.0).is_some());

    let (lights, casters, _) = stage();
    let cfg = AtlasConfig::default();
    assert_eq!(Atlas::new(&[], &casters, None, &cfg).unwrap_err(), AtlasError::NoLights);
    assert_eq!(Atlas::new(&lights, &[], None, &cfg).unwrap_err(), AtlasError::NoCasters);
    let bad_light = [AtlasLight::Local { center: Vec3::ZERO, radius: -1.0, power: 1.0, emit: None }];
    assert!(matches!(Atlas::new(&bad_light, &casters, None, &cfg), Err(AtlasError::Light { index: 0, .. })));
    let bad_sun = [AtlasLight::Distant { to_light: Vec3::ZERO, irradiance: 1.0, cos_half_angle: 1.0 }];
    assert!(matches!(Atlas::new(&bad_sun, &casters, None, &cfg), Err(AtlasError::Light { index: 0, .. })));
    let bad_caster = [Caster { center: Vec3::ZERO, radius: 0.0 }];
    assert!(matches!(Atlas::new(&lights, &bad_caster, None, &cfg), Err(AtlasError::Caster { index: 0, .. })));
    assert_eq!(Atlas::new(&lights, &casters, Some(&[(0, 9)]), &cfg).unwrap_err(), AtlasError::Pair { index: 0 });
    let zero = [AtlasLight::Local { center: Vec3::ZERO, radius: 0.0, power: 0.0, emit: None }];
    assert_eq!(Atlas::new(&zero, &casters, None, &cfg).unwrap_err(), AtlasError::NoImportance);
    let tiny = AtlasConfig { width: 2, height: 2, ..cfg };
    assert!(matches!(Atlas::new(&lights, &casters, None, &tiny), Err(AtlasError::TooManyPairs { .. })));
    assert!(matches!(Atlas::new(&lights, &casters, None, &AtlasConfig { width: 0, ..cfg }), Err(AtlasError::TableSize { .. })));
    assert_eq!(Atlas::new(&lights, &casters, None, &AtlasConfig { defensive: 2.0, ..cfg }).unwrap_err(), AtlasError::Defensive(2.0));
    let cam = Some(CameraHint { position: Vec3::ZERO, solid_angle: 0.0 });
    assert_eq!(Atlas::new(&lights, &casters, None, &AtlasConfig { camera: cam, ..cfg }).unwrap_err(), AtlasError::Camera);
    let mut atlas = Atlas::new(&lights, &casters, None, &cfg).unwrap();
    let other = Atlas::new(&lights, &casters, None, &AtlasConfig { width: 16, height: 16, ..cfg }).unwrap();
    assert!(matches!(VisibilityBuffer::new(&atlas, 0.0), Err(AtlasError::Unit(_))));
    let vis = VisibilityBuffer::new(&other, 1.0).unwrap();
    assert!(matches!(atlas.end_pass(&vis, 10), Err(AtlasError::BufferMismatch { .. })));
    let vis = VisibilityBuffer::new(&atlas, 1.0).unwrap();
    vis.record(u32::MAX, VisibilityKind::Surface, 1.0);
    vis.record(0, VisibilityKind::Surface, f32::NAN);
    assert_eq!(atlas.end_pass(&vis, 0).unwrap_err(), AtlasError::NoSamples);
    // out-of-range numbers still give a valid cell
    for u in [[1.0, 1.0], [f32::NAN, -3.0], [0.0, 0.0]] {
        let s = atlas.sample(u);
        assert!(atlas.pair_of_cell(s.cell).is_some() && s.pdf_local > 0.0);
    }
    assert!(AtlasError::NoSamples.to_string().contains("camera sample"));
}


#[test]
fn renderer_lights_become_atlas_lights() {
    use crate::light::Light;
    use crate::spectrum::Spectrum;
    let point = Light::point(Vec3::new(1.0, 2.0, 3.0), Spectrum::Constant(1.0), 5.0);
    let Some(AtlasLight::Local { center, radius, power, .. }) = AtlasLight::from_light(&point) else { panic!("point light") };
    assert_eq!((center, radius), (Vec3::new(1.0, 2.0, 3.0), 0.0));
    assert_eq!(power, point.power());
    assert!(power > 0.0);
    let tri = Light::triangle([Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0], Spectrum::Constant(1.0), false).unwrap();
    let Some(AtlasLight::Local { center, radius, .. }) = AtlasLight::from_light(&tri) else { panic!("triangle light") };
    assert!((center - Vec3::new(2.0, 2.0, 0.0) / 3.0).length() < 1e-6);
    // the farthest corner from the centroid: (2,0) or (0,2) at √(16/9 + 4/9)
    assert!((radius - (20.0f32 / 9.0).sqrt()).abs() < 1e-5);
}

/// One distant light over one wide caster (radius 10); photons are "useful" only when they start
/// within 1.5 of (3, 2) in the light's perpendicular plane (a small visible region of a large
/// water surface).
fn refit_stage() -> (Atlas, Frame, Vec3) {
    let to_light = Vec3::new(0.2, 1.0, -0.3).normalize();
    let lights = [AtlasLight::Distant { to_light, irradiance: 3.0, cos_half_angle: 0.99999 }];
    let casters = [Caster { center: Vec3::new(1.0, -2.0, 0.5), radius: 10.0 }];
    let atlas = Atlas::new(&lights, &casters, None, &AtlasConfig { width: 32, height: 32, ..Default::default() }).unwrap();
    (atlas, Frame::from_normal(-to_light), casters[0].center)
}

const USEFUL: ([f32; 2], f32) = ([3.0, 2.0], 1.5);

/// A learning pass of `n` photons drawn with the defensive mixture: each useful one records a
/// float-valued signal in its cell, from any thread.
fn refit_pass(atlas: &mut Atlas, frame: &Frame, center: Vec3, n: u32, pass: u32) {
    let vis = VisibilityBuffer::new(atlas, 1.0).unwrap();
    (0..n).into_par_iter().for_each(|i| {
        let mut rng = TestRng::new(((pass as u64) << 32) | i as u64 | 1 << 63);
        let mut s = atlas.sample([rng.next_f32(), rng.next_f32()]);
        let (um, ud) = (rng.next_f32(), [rng.next_f32(), rng.next_f32()]);
        let e = atlas.emit_mixture(&mut s, Vec3::ZERO, um, ud).unwrap();
        let v = frame.to_local(e.origin - center);
        let (c, r) = USEFUL;
        if (v.x - c[0]).powi(2) + (v.y - c[1]).powi(2) < r * r {
            vis.record(s.cell, VisibilityKind::Surface, (0.5 + rng.next_f32()) / (n as f32 * e.pdf));
        }
    });
    atlas.end_pass(&vis, n as u64).unwrap();
}

fn refit_atlas(passes: u32) -> (Atlas, Frame, Vec3) {
    let (mut atlas, frame, center) = refit_stage();
    for pass in 0..passes {
        refit_pass(&mut atlas, &frame, center, 40_000, pass);
    }
    (atlas, frame, center)
}

// After two passes the disk shrinks to the useful region (with its margin), holds all of it,
// and saves at least half the area; before pass 2 nothing changes.
#[test]
fn the_disk_is_refit_to_the_useful_cells_after_the_second_pass() {
    let (one, ..) = refit_atlas(1);
    assert!(one.pair_disk(0).is_none() && one.disk_area_ratio() == Some(1.0));
    let (atlas, ..) = refit_atlas(2);
    let d = atlas.pair_disk(0).expect("refit after pass 2");
    let (c, r) = USEFUL;
    let reach = ((d.offset[0] - c[0]).powi(2) + (d.offset[1] - c[1]).powi(2)).sqrt() + r;
    assert!(reach <= d.radius, "refit disk {d:?} must hold the useful circle");
    let ratio = atlas.disk_area_ratio().unwrap();
    assert!(ratio <= REFIT_MAX_AREA_RATIO && (ratio / (d.radius / 10.0).powi(2) - 1.0).abs() < 1e-5, "area ratio {ratio}");
    assert_eq!(atlas.refits(), 1);
    // the pair's table restarts uniform over its square (visibility forgotten)
    let (_, _, vis) = atlas.visibility_image();
    assert!(vis.iter().all(|&v| v == 0.0));
    let (_, _, img) = atlas.to_image();
    assert!(img.iter().all(|&v| v == 1.0), "uniform over the pair's square");
}

// The defensive mixture on a refit disk against `pdf_position`: positions mapped to the upper
// hemisphere by the equal-area map of a disk of radius 12 (the original disk, radius 10, and the
// refit disk lie inside it). Also: each photon's pdf is `pdf_position` at its start, and photons
// outside the refit disk carry the pair's out-of-table cell id.
#[test]
fn refit_position_sampling_passes_chi2_against_its_pdf() {
    let (atlas, frame, center) = refit_atlas(4);
    let d = atlas.pair_disk(0).expect("refit");
    let big = 12.0f32;
    let (mut outside, mut agree, mut total) = (0u32, 0u32, 0u32);
    let mut rng = TestRng::new(99);
    for _ in 0..20_000 {
        let mut s = atlas.sample([rng.next_f32(), rng.next_f32()]);
        let e = atlas.emit_mixture(&mut s, Vec3::ZERO, rng.next_f32(), [rng.next_f32(), rng.next_f32()]).unwrap();
        let v = frame.to_local(e.origin - center);
        let r_refit = ((v.x - d.offset[0]).powi(2) + (v.y - d.offset[1]).powi(2)).sqrt();
        if r_refit >= d.radius {
            outside += 1;
            assert_eq!(s.cell as usize, atlas.cell_count(), "out-of-table id of pair 0");
            assert_eq!(atlas.pair_of_cell(s.cell), Some(&atlas.pairs()[0]));
        } else {
            assert!((s.cell as usize) < atlas.cell_count());
        }
        total += 1;
        let p = atlas.pdf_position(0, e.origin);
        // f32 relative rounding; a start within rounding of a cell edge may read the neighbour
        if (p / e.pdf - 1.0).abs() < 1e-4 {
            agree += 1;
        }
    }
    // the uniform branch (10%) lands outside the refit disk with probability 1 − (area ratio)
    assert!(outside > total / 20, "outside the refit disk: {outside} of {total}");
    assert!(agree as f32 > 0.999 * total as f32, "photon pdf equals pdf_position: {agree} of {total}");
    let cfg = Chi2Config { theta_res: 16, phi_res: 32, samples: 300_000, quad_res: 32, ..Default::default() };
    let r = chi2_sphere(
        cfg,
        |rng| {
            let mut s = atlas.sample([rng.next_f32(), rng.next_f32()]);
            let e = atlas.emit_mixture(&mut s, Vec3::ZERO, rng.next_f32(), [rng.next_f32(), rng.next_f32()])?;
            let v = frame.to_local(e.origin - center);
            let (a, b) = (v.x / big, v.y / big);
            let rho2 = a * a + b * b;
            assert!(rho2 < 1.0, "the test's disk holds both disks");
            let k = (2.0 - rho2).sqrt();
            Some(Vec3::new(a * k, b * k, 1.0 - rho2))
        },
        |dir| {
            if dir.z <= 0.0 {
                return 0.0;
            }
            let rho = (1.0 - dir.z).max(0.0).sqrt();
            let phi = dir.y.atan2(dir.x);
            let p = center + frame.to_world(Vec3::new(big * rho * phi.cos(), big * rho * phi.sin(), 0.0));
            atlas.pdf_position(0, p) * big * big / 2.0
        },
    );
    assert!(r.passed(0.01, 1), "{r:?}");
    // midpoint quadrature of a density with disk edges and cell steps, as above
    assert!((r.pdf_integral - 1.0).abs() < 5e-3, "{r:?}");
}

// The refit depends only on the fixed-point sums: identical disks, tables and signals for 1 and
// 2 threads over two refit checks (passes 2 and 4).
#[test]
fn refit_is_identical_on_one_and_two_threads() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let (atlas, ..) = refit_atlas(5);
            (atlas.pair_disk(0), atlas.to_image().2, atlas.visibility_image().2)
        })
    };
    let (d1, t1, v1) = run(1);
    let (d2, t2, v2) = run(2);
    assert!(d1.is_some());
    assert_eq!(d1.map(|d| (d.offset.map(f32::to_bits), d.radius.to_bits())), d2.map(|d| (d.offset.map(f32::to_bits), d.radius.to_bits())));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&t1), bits(&t2), "learned tables differ");
    assert_eq!(bits(&v1), bits(&v2), "visibility signals differ");
}

// Switched off, the disk stays the caster's.
#[test]
fn refit_can_be_switched_off() {
    let (lights, casters) = {
        let (a, ..) = refit_stage();
        (a.lights().to_vec(), a.casters().to_vec())
    };
    let (_, frame, center) = refit_stage();
    let mut atlas = Atlas::new(&lights, &casters, None, &AtlasConfig { width: 32, height: 32, disk_refit: false, ..Default::default() }).unwrap();
    for pass in 0..4 {
        refit_pass(&mut atlas, &frame, center, 20_000, pass);
    }
    assert!(atlas.pair_disk(0).is_none() && atlas.refits() == 0 && atlas.disk_area_ratio() == Some(1.0));
}

/// The atlas weighs a light–caster pair by what the light sends the caster: of two spots of
/// one power beside a caster, the one aimed away (and a rect facing away) get no share of the
/// photons, the one aimed at it all of them (by power alone each spot took half).
#[test]
fn a_spot_aimed_away_from_a_caster_gets_no_photons() {
    use crate::light::tests::{build, desc};
    use crate::scene::{LightShape, ShapingDesc};
    use glam::{Mat4, Quat};
    // lights shine along their local −Z; the caster 5 m along −Z from the origin
    let caster = [Caster { center: Vec3::new(0.0, 0.0, -5.0), radius: 0.5 }];
    let spot = |rot: Quat| {
        let mut d = desc(LightShape::Sphere { radius: 0.0, treat_as_point: true }, Mat4::from_quat(rot));
        d.shaping = Some(ShapingDesc { cone_angle_deg: 30.0, ..Default::default() });
        AtlasLight::from_light(&build(&d)).unwrap()
    };
    let (toward, away) = (spot(Quat::IDENTITY), spot(Quat::from_rotation_y(std::f32::consts::PI)));
    let rect = AtlasLight::from_light(&build(&desc(LightShape::Rect { width: 1.0, height: 1.0, texture: None }, Mat4::from_rotation_y(std::f32::consts::PI)))).unwrap();
    let cfg = AtlasConfig { width: 32, height: 32, ..Default::default() };
    let atlas = Atlas::new(&[away, toward, rect], &caster, None, &cfg).unwrap();
    let share = |light: u32| -> f32 {
        let cells: Vec<u32> = (0..atlas.cell_count() as u32).filter(|&c| atlas.pair_of_cell(c).is_some_and(|p| p.light == light)).collect();
        cells.iter().map(|&c| atlas.cell_probability(c)).sum()
    };
    assert_eq!(share(0), 0.0, "the spot aimed away");
    assert_eq!(share(2), 0.0, "the rect facing away");
    assert!((share(1) - 1.0).abs() < 1e-4, "the spot aimed at the caster: {}", share(1));
    // with emission all round (no bounds) both spots take the same share
    let unbounded = |l: AtlasLight| match l {
        AtlasLight::Local { center, radius, power, .. } => AtlasLight::Local { center, radius, power, emit: None },
        other => other,
    };
    let atlas = Atlas::new(&[unbounded(away), unbounded(toward)], &caster, None, &cfg).unwrap();
    let p: Vec<f32> = (0..2).map(|l| atlas.pairs().iter().filter(|p| p.light == l).map(|p| p.importance).sum()).collect();
    assert!(p[0] > 0.0 && (p[0] - p[1]).abs() <= 1e-6 * p[0], "{p:?}");
}
