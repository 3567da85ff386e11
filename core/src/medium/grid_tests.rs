//! Tests of the density-grid medium: the majorant grid bounds the density along any ray and its
//! segments cover the box exactly; Beer–Lambert through a constant grid (analytic optical
//! depth, ramps of trilinear interpolation included); delta and ratio tracking against f64
//! quadrature through a random grid under a rotated, non-uniformly scaled placement, per
//! wavelength within 3 standard errors; χ² of the collision distance against the mixture of
//! the channels' free-flight densities; determinism.

use super::grid::*;
use super::tests::{chi2_1d, Moments};
use super::*;
use crate::spectrum::{Spectrum, N_SPECTRUM};
use crate::testing::chi2::TestRng;
use glam::{Mat4, Quat};

fn all_live() -> SampledWavelengths {
    SampledWavelengths::sample_uniform(0.3)
}

/// Coefficients that differ by an order of magnitude across the wavelengths, like water's.
fn medium(grid: DensityGrid, absorbing_only: bool) -> GridMedium {
    let sa = Spectrum::tabulated(&[360.0, 830.0], &[0.3, 4.0]).unwrap();
    let ss = if absorbing_only { Spectrum::Constant(0.0) } else { Spectrum::tabulated(&[360.0, 830.0], &[1.5, 0.2]).unwrap() };
    GridMedium { grid, sigma_a: sa, sigma_s: ss, phase: PhaseFunction::Isotropic }
}

fn random_grid(seed: u64) -> DensityGrid {
    let dims = [11u32, 7, 13];
    let mut rng = TestRng::new(seed);
    // a third of the voxels empty, the rest in [0, 2): sparse-looking, with sharp edges
    let values: Vec<f32> = (0..dims.iter().product::<u32>()).map(|_| if rng.next_f32() < 0.33 { 0.0 } else { 2.0 * rng.next_f32() }).collect();
    let xf = Mat4::from_scale_rotation_translation(Vec3::new(0.11, 0.2, 0.07), Quat::from_euler(glam::EulerRot::XYZ, 0.4, -0.7, 1.1), Vec3::new(0.3, -0.2, 0.5));
    DensityGrid::new(dims, &values, xf).unwrap()
}

/// A ray from outside through the grid's box: from a point 1.5 box-radii from the centre
/// towards a random point near the centre.
fn random_ray(g: &DensityGrid, rng: &mut TestRng) -> (Vec3, Vec3, f32) {
    let (lo, hi) = g.local_bounds();
    let xf = g.local_to_world();
    let c = xf.transform_point3((lo + hi) * 0.5);
    let r = (xf.transform_point3(hi) - xf.transform_point3(lo)).length() * 0.5;
    let mut dir = || Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
    let o = c + dir() * 1.5 * r;
    let target = c + dir() * 0.3 * r;
    ((o), (target - o).normalize(), 3.0 * r)
}

/// ∫_0^x ρ along the ray at each of `edges` (f64 trapezoid, 20 000 steps per unit of the
/// longest edge: the density is piecewise trilinear with cells ≥ 0.07 long, so the error is
/// far below the Monte Carlo error).
fn optical_depths(g: &DensityGrid, o: Vec3, d: Vec3, edges: &[f64]) -> Vec<f64> {
    let len = edges.last().copied().unwrap_or(0.0);
    let steps = (20_000.0 * len.max(1.0)) as usize;
    let h = len / steps as f64;
    let rho = |t: f64| g.density(o + d * t as f32) as f64;
    let mut out = Vec::with_capacity(edges.len());
    let mut acc = 0.0;
    let mut prev = rho(0.0);
    let mut e = 0;
    for i in 0..=steps {
        let t = i as f64 * h;
        if i > 0 {
            let cur = rho(t);
            acc += 0.5 * h * (prev + cur);
            prev = cur;
        }
        while e < edges.len() && edges[e] <= t + 0.5 * h {
            out.push(acc);
            e += 1;
        }
    }
    while out.len() < edges.len() {
        out.push(acc);
    }
    out
}

#[test]
fn majorant_segments_bound_the_density_and_cover_the_box() {
    check_majorants(&random_grid(1), 2, None);
}

/// A grid of `dims` values (x fastest), zero but in the `blobs` ([lo, hi) per axis), whose
/// values are random in [base, base + span).
fn blobs_grid(dims: [u32; 3], blobs: &[([usize; 3], [usize; 3])], seed: u64, base: f32, span: f32) -> Vec<f32> {
    let d = dims.map(|v| v as usize);
    let mut values = vec![0f32; d[0] * d[1] * d[2]];
    let mut rng = TestRng::new(seed);
    for &(lo, hi) in blobs {
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    values[x + d[0] * (y + d[1] * z)] = base + span * rng.next_f32();
                }
            }
        }
    }
    values
}

/// A grid mostly empty, its values in a few blobs that straddle brick boundaries, as a
/// spray or foam VDB is: only the blobs' bricks are stored, the values read back exactly, and
/// the majorants (skipping super-voxels whose bricks are all empty) still bound every lookup
/// on rays through the blobs.
#[test]
fn a_sparse_grid_keeps_only_its_occupied_bricks_and_its_majorants_bound_it() {
    use super::grid::{Bricks, BRICK};
    let dims = [45u32, 29, 61];
    // blobs [lo, hi) per axis, each across a brick boundary (multiples of 8), the first
    // ending on a brick's last layer (y = 15): lookups in the next super-voxel read it
    let blobs = [([5, 10, 6], [11, 16, 10]), ([30, 2, 38], [34, 9, 42]), ([39, 22, 55], [45, 29, 61])];
    let mut values = blobs_grid(dims, &blobs, 5, 0.5, 2.0);
    values[3] = f32::NAN;
    values[4] = -1.0;
    let b = Bricks::from_dense(dims, &values).unwrap();
    let occupied = |lo: [usize; 3], hi: [usize; 3]| (0..3).map(|k| (hi[k] - 1) / BRICK - lo[k] / BRICK + 1).product::<usize>();
    assert_eq!(b.stored(), blobs.iter().map(|&(lo, hi)| occupied(lo, hi)).sum::<usize>());
    let clean: Vec<f32> = values.iter().map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 }).collect();
    assert_eq!(b.to_dense(), clean);
    assert!(b.memory_bytes() * 4 < values.len() * 4, "{} bytes for {} values", b.memory_bytes(), values.len());
    // as a reader hands them over: the same grid
    let (coords, pool) = occupied_bricks(dims, &values);
    assert_eq!(Bricks::from_coords(dims, &coords, pool.clone()).unwrap().to_dense(), clean);
    let none = Bricks::from_coords(dims, &[], Vec::new()).unwrap();
    assert!(none.stored() == 0 && none.to_dense().iter().all(|&v| v == 0.0));
    assert!(Bricks::from_coords(dims, &coords[3..], pool.clone()).is_err(), "fewer coordinates than bricks");
    let mut twice = coords.clone();
    twice[3..6].copy_from_slice(&coords[..3]);
    assert!(Bricks::from_coords(dims, &twice, pool.clone()).unwrap_err().contains("twice"));
    let mut outside = coords.clone();
    outside[1] = 4;
    assert!(Bricks::from_coords(dims, &outside, pool).unwrap_err().contains("outside"), "29 voxels are 4 bricks in y");
    let xf = Mat4::from_scale_rotation_translation(Vec3::new(0.05, 0.08, 0.03), Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.9, -0.4), Vec3::new(-0.5, 0.2, 1.0));
    let g = DensityGrid::new(dims, &values, xf).unwrap();
    let centres: Vec<Vec3> = blobs.iter().map(|&(lo, hi)| xf.transform_point3((Vec3::from(lo.map(|v| v as f32)) + Vec3::from(hi.map(|v| v as f32))) * 0.5)).collect();
    check_majorants(&g, 6, Some(&centres));
}

/// The coordinates and values of the bricks of `values` (x fastest over `dims`) that hold
/// anything, as a reader hands them over.
fn occupied_bricks(dims: [u32; 3], values: &[f32]) -> (Vec<u32>, Vec<f32>) {
    use super::grid::BRICK;
    let d = dims.map(|v| v as usize);
    let (mut coords, mut pool) = (Vec::new(), Vec::new());
    for bz in 0..d[2].div_ceil(BRICK) {
        for by in 0..d[1].div_ceil(BRICK) {
            for bx in 0..d[0].div_ceil(BRICK) {
                let brick: Vec<f32> = (0..BRICK * BRICK * BRICK)
                    .map(|k| {
                        let (x, y, z) = (bx * BRICK + k % BRICK, by * BRICK + k / BRICK % BRICK, bz * BRICK + k / (BRICK * BRICK));
                        if x < d[0] && y < d[1] && z < d[2] { values[x + d[0] * (y + d[1] * z)] } else { 0.0 }
                    })
                    .collect();
                if brick.iter().any(|&v| v != 0.0) {
                    coords.extend([bx as u32, by as u32, bz as u32]);
                    pool.extend(brick);
                }
            }
        }
    }
    (coords, pool)
}

/// A sparse grid over a box of many nodes (64³ voxels each), its blobs on node boundaries and
/// on a brick's last layer next to an empty node, others alone in the middle of a node: the
/// two-level table holds the occupied nodes only, the values read back exactly, rays crossing
/// empty nodes take one segment per node, and the majorants still bound every lookup.
#[test]
fn a_grid_over_many_nodes_stores_and_walks_only_its_occupied_ones() {
    use super::grid::{Bricks, BRICK, NODE, SUPER};
    let dims = [300u32, 140, 330];
    let d = dims.map(|v| v as usize);
    // [lo, hi) per axis: across the node boundaries at 64 and 128 (x, y), ending on the last
    // layer of node 1 in z (z = 127, read by the super-voxels of node 2), alone inside a node
    let blobs = [([60, 60, 120], [70, 70, 128]), ([126, 126, 190], [131, 131, 196]), ([220, 20, 280], [226, 27, 285]), ([13, 100, 20], [16, 104, 23])];
    let values = blobs_grid(dims, &blobs, 8, 0.25, 3.0);
    let b = Bricks::from_dense(dims, &values).unwrap();
    assert_eq!(b.to_dense(), values);
    let (coords, pool) = occupied_bricks(dims, &values);
    assert_eq!(b.stored(), pool.len() / (BRICK * BRICK * BRICK));
    // the table: an entry per node of the box (5 × 3 × 6) and 512 per node holding a brick
    // (a blob across node boundaries occupies up to eight: 14 in all)
    let box_nodes = d.iter().map(|&n| n.div_ceil(BRICK * NODE)).product::<usize>();
    let mut nodes: Vec<[u32; 3]> = coords.chunks_exact(3).map(|c| [c[0], c[1], c[2]].map(|v| v / NODE as u32)).collect();
    nodes.sort_unstable();
    nodes.dedup();
    assert_eq!(nodes.len(), 14);
    assert_eq!(b.memory_bytes() - pool.len() * 4, box_nodes * 4 + nodes.len() * NODE * NODE * NODE * 4);
    assert_eq!(Bricks::from_coords(dims, &coords, pool).unwrap(), b);
    let xf = Mat4::from_scale_rotation_translation(Vec3::new(0.01, 0.013, 0.008), Quat::from_euler(glam::EulerRot::XYZ, -0.2, 0.5, 0.3), Vec3::new(0.4, -1.0, 0.2));
    let g = DensityGrid::new(dims, &values, xf).unwrap();
    let centres: Vec<Vec3> = blobs.iter().map(|&(lo, hi)| xf.transform_point3((Vec3::from(lo.map(|v| v as f32)) + Vec3::from(hi.map(|v| v as f32))) * 0.5)).collect();
    check_majorants(&g, 9, Some(&centres));
    check_majorants(&g, 10, None);
    // along x through an empty row of the box: one segment per node of super-voxels
    let o = xf.transform_point3(Vec3::new(-5.0, 30.5, 40.5));
    let dir = xf.transform_vector3(Vec3::X).normalize();
    let segs: Vec<_> = g.segments(o, dir, 1e3).collect();
    let super_nodes = (d[0] + 1).div_ceil(SUPER).div_ceil(NODE);
    assert_eq!(segs.len(), super_nodes, "{segs:?}");
    assert!(segs.iter().all(|s| s.2 == 0.0));
}

/// Every segment's majorant bounds the density along random rays (aimed at the box's middle,
/// or at one of `targets`), and its minorant from below; the segments cover the box.
fn check_majorants(g: &DensityGrid, seed: u64, targets: Option<&[Vec3]>) {
    let g = g.clone();
    let mut rng = TestRng::new(seed);
    for i in 0..500 {
        let (o, d, len) = random_ray(&g, &mut rng);
        let (o, d, len) = match targets {
            Some(t) => {
                let aim = t[i % t.len()] + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5) * 0.2;
                (o, (aim - o).normalize(), len)
            }
            None => (o, d, len),
        };
        let mut it = g.segments(o, d, len);
        while let Some((t0, t1, _)) = it.next() {
            let c = it.minorant();
            for k in 0..=16 {
                let t = t0 + (t1 - t0) * k as f32 / 16.0;
                // the same rounding slack as for the majorant below
                assert!(g.density(o + d * t) >= c * (1.0 - 1e-5) - 1e-5, "ρ below the minorant {c} at t {t}");
            }
        }
        let segs: Vec<(f32, f32, f32)> = g.segments(o, d, len).collect();
        assert!(!segs.is_empty(), "every ray aims at the box's middle");
        for w in segs.windows(2) {
            assert!((w[0].1 - w[1].0).abs() <= 1e-5 * len, "segments are contiguous: {w:?}");
        }
        for &(t0, t1, m) in &segs {
            for k in 0..=16 {
                let t = t0 + (t1 - t0) * k as f32 / 16.0;
                let rho = g.density(o + d * t);
                // the majorant is a max over the same f32 values the lookup interpolates:
                // the slack is rounding of the interpolation and of t at the super-voxel faces
                assert!(rho <= m * (1.0 + 1e-5) + 1e-5, "ρ {rho} > majorant {m} at t {t} in [{t0}, {t1}]");
            }
        }
        // before the first and after the last segment the ray is outside the box: ρ = 0
        let (first, last) = (segs[0].0, segs[segs.len() - 1].1);
        for k in 0..16 {
            let before = first * k as f32 / 16.0 * 0.999;
            let after = last + (len - last) * (k as f32 + 0.5) / 16.0;
            assert_eq!(g.density(o + d * before), 0.0);
            assert!(g.density(o + d * after) <= 1e-4, "density beyond the box at t {after}");
        }
    }
    // a ray that misses the box has no segment
    let (lo, hi) = g.local_bounds();
    let far = g.local_to_world().transform_point3(hi + (hi - lo));
    assert_eq!(g.segments(far, (far - g.local_to_world().transform_point3(lo)).normalize(), 100.0).count(), 0);
}

#[test]
fn constant_grid_transmittance_is_beer_lambert() {
    // a 6³ grid of ones with voxels 0.125 wide: along a row of grid points the density ramps
    // up over one voxel, is 1 over 5 voxels and ramps down over one: ∫ρ = (0.5 + 5 + 0.5)/8
    // (T between 0.03 and 0.3 across the channels: well inside what 50 000 samples resolve)
    let g = DensityGrid::new([6, 6, 6], &[1.0; 216], Mat4::from_scale_rotation_translation(Vec3::splat(0.125), Quat::IDENTITY, Vec3::new(-1.0, 2.0, 0.0))).unwrap();
    let o = g.local_to_world().transform_point3(Vec3::new(-4.0, 2.0, 3.0));
    let d = Vec3::X;
    let optical = 0.75f64;
    let lambda = all_live();
    for absorbing_only in [true, false] {
        let m = medium(g.clone(), absorbing_only);
        let (a, s) = m.coefficients(&lambda);
        let st = a + s;
        let expected: [f64; N_SPECTRUM] = std::array::from_fn(|j| (-(st[j] as f64) * optical).exp());
        let n = 50_000;
        let (mut ratio, mut pass) = (Moments::new(n), Moments::new(n));
        let mut rng = TestRng::new(11);
        for _ in 0..n {
            let mut r = || rng.next_f32();
            let tr = m.transmittance(o, d, 20.0, &mut r, &lambda);
            assert!(tr.0.iter().all(|v| (0.0..=1.0).contains(v)));
            ratio.add(tr);
            match m.sample_distance(o, d, 20.0, &mut r, &lambda) {
                DistanceSample::Pass { weight } => pass.add(weight),
                DistanceSample::Scatter { .. } => pass.add(SampledSpectrum::ZERO),
            }
        }
        ratio.check(expected, "ratio tracking through a constant grid = exp(−σt·0.75)");
        pass.check(expected, "delta tracking's passing weight through a constant grid = exp(−σt·0.75)");
    }
}

#[test]
fn residual_ratio_tracking_is_exact_and_draws_nothing_where_the_density_is_constant() {
    // a 24³ grid of 0.8: the super-voxels away from the edges (grid points 7 to 16) have
    // minorant = majorant, so a segment inside them is attenuated exactly
    let g = DensityGrid::new([24, 24, 24], &vec![0.8; 24 * 24 * 24], Mat4::from_scale(Vec3::splat(0.1))).unwrap();
    let m = medium(g, false);
    let lambda = all_live();
    let (a, s) = m.coefficients(&lambda);
    let o = Vec3::new(0.75, 1.2, 1.0);
    let mut draws = 0;
    let mut r = || {
        draws += 1;
        0.5
    };
    let tr = m.transmittance(o, Vec3::X, 0.7, &mut r, &lambda);
    assert_eq!(draws, 0);
    for j in 0..N_SPECTRUM {
        let exact = (-(a[j] + s[j]) * 0.8 * 0.7).exp();
        // f32 exponentials of a product computed in another order
        assert!((tr[j] - exact).abs() <= 1e-5 * exact, "{} vs {exact}", tr[j]);
    }
}

/// Delta tracking: E[1_pass w] = T(L), E[1_scatter w] = ∫σs T, E[1_scatter w t] = ∫ t σs T;
/// ratio tracking: E[T̂] = T(L); all per wavelength against quadrature.
fn check_random_ray(m: &GridMedium, o: Vec3, d: Vec3, len: f32, lambda: &SampledWavelengths, seed: u64) {
    let (a, s) = m.coefficients(lambda);
    let st = a + s;
    let k = 4000;
    let edges: Vec<f64> = (0..=k).map(|i| len as f64 * i as f64 / k as f64).collect();
    let tau = optical_depths(&m.grid, o, d, &edges);
    let h = len as f64 / k as f64;
    let mut refs = [[0.0f64; N_SPECTRUM]; 3];
    for j in 0..N_SPECTRUM {
        if lambda.pdf[j] <= 0.0 {
            continue;
        }
        refs[0][j] = (-(st[j] as f64) * tau[k]).exp();
        // ∫ σs ρ T dt = (σs/σt)(1 − T(L)) exactly, since d/dt(−T) = σt ρ T
        refs[1][j] = if st[j] > 0.0 { s[j] as f64 / st[j] as f64 * (1.0 - refs[0][j]) } else { 0.0 };
        // ∫ t σs ρ T dt = (σs/σt)(∫_0^L T dt − L·T(L)) by parts; ∫T by the trapezoid rule
        let int_t: f64 = (0..k).map(|i| 0.5 * h * ((-(st[j] as f64) * tau[i]).exp() + (-(st[j] as f64) * tau[i + 1]).exp())).sum();
        refs[2][j] = if st[j] > 0.0 { s[j] as f64 / st[j] as f64 * (int_t - len as f64 * refs[0][j]) } else { 0.0 };
    }
    let n = 100_000;
    let mut rng = TestRng::new(seed);
    let mut mom = [Moments::new(n), Moments::new(n), Moments::new(n), Moments::new(n)];
    for _ in 0..n {
        let mut r = || rng.next_f32();
        let ev = m.sample_distance(o, d, len, &mut r, lambda);
        let w = ev.weight();
        assert!(w.is_finite() && w.0.iter().all(|&v| (0.0..=N_SPECTRUM as f32 + 1e-3).contains(&v)), "weight {w:?} outside [0, N]");
        match ev {
            DistanceSample::Pass { weight } => {
                mom[0].add(weight);
                mom[1].add(SampledSpectrum::ZERO);
                mom[2].add(SampledSpectrum::ZERO);
            }
            DistanceSample::Scatter { t, weight } => {
                assert!((0.0..len).contains(&t));
                mom[0].add(SampledSpectrum::ZERO);
                mom[1].add(weight);
                mom[2].add(weight * t);
            }
        }
        let tr = m.transmittance(o, d, len, &mut r, lambda);
        assert!(tr.0.iter().all(|v| (0.0..=1.0).contains(v)));
        mom[3].add(tr);
    }
    mom[0].check(refs[0], "E[1_pass w] = T(L)");
    mom[1].check(refs[1], "E[1_scatter w] = ∫σs T");
    mom[2].check(refs[2], "E[1_scatter w t] = ∫ t σs T");
    mom[3].check(refs[0], "E[ratio tracking] = T(L)");
}

#[test]
fn delta_and_ratio_tracking_agree_with_quadrature_through_a_random_grid() {
    let g = random_grid(3);
    let mut rng = TestRng::new(4);
    let lambda = all_live();
    for seed in 0..3 {
        let (o, d, len) = random_ray(&g, &mut rng);
        check_random_ray(&medium(g.clone(), false), o, d, len, &lambda, 40 + seed);
    }
    // a ray that starts inside the box and ends inside it, hero wavelength only
    let (o, d, len) = random_ray(&g, &mut rng);
    let mut hero = all_live();
    hero.terminate_secondary();
    check_random_ray(&medium(g.clone(), false), o + d * 0.4 * len, d, 0.3 * len, &hero, 50);
    // purely absorbing: never a collision, the passing weight is the transmittance
    check_random_ray(&medium(g, true), o, d, len, &lambda, 51);
}

#[test]
fn collision_distance_follows_the_mixture_of_free_flight_densities() {
    // channel c's first real collision has density σt_c ρ(t) T_c(t); c is uniform, so
    // P(t < x) = (1/N) Σ_c (1 − T_c(x)) and P(pass) the rest
    let g = random_grid(5);
    let m = medium(g, false);
    let lambda = all_live();
    let (a, s) = m.coefficients(&lambda);
    let st = a + s;
    let mut rng = TestRng::new(6);
    let (o, d, len) = random_ray(&m.grid, &mut rng);
    let bins = 60;
    let edges: Vec<f64> = (0..=bins).map(|i| len as f64 * i as f64 / bins as f64).collect();
    let tau = optical_depths(&m.grid, o, d, &edges);
    let cdf = |i: usize| (0..N_SPECTRUM).map(|j| 1.0 - (-(st[j] as f64) * tau[i]).exp()).sum::<f64>() / N_SPECTRUM as f64;
    let mut probs: Vec<f64> = (0..bins).map(|i| cdf(i + 1) - cdf(i)).collect();
    probs.push(1.0 - cdf(bins));
    let n = 200_000;
    let mut obs = vec![0.0; bins + 1];
    for _ in 0..n {
        let mut r = || rng.next_f32();
        match m.sample_distance(o, d, len, &mut r, &lambda) {
            DistanceSample::Scatter { t, .. } => obs[((t / len * bins as f32) as usize).min(bins - 1)] += 1.0,
            DistanceSample::Pass { .. } => obs[bins] += 1.0,
        }
    }
    let pv = chi2_1d(&obs, &probs, n);
    // one test at 1 % significance
    assert!(pv > 0.01, "p-value {pv}");
}

#[test]
fn grid_tracking_is_deterministic() {
    let m = medium(random_grid(7), false);
    let lambda = all_live();
    let run = || {
        let mut rng = TestRng::new(8);
        let mut out = Vec::new();
        for _ in 0..200 {
            let (o, d, len) = random_ray(&m.grid, &mut rng);
            let mut r = || rng.next_f32();
            let ev = m.sample_distance(o, d, len, &mut r, &lambda);
            let tr = m.transmittance(o, d, len, &mut r, &lambda);
            let t = if let DistanceSample::Scatter { t, .. } = ev { t } else { -1.0 };
            out.push((t.to_bits(), ev.weight().0.map(f32::to_bits), tr.0.map(f32::to_bits)));
        }
        out
    };
    assert_eq!(run(), run());
}

#[test]
fn a_ray_missing_the_box_passes_unchanged() {
    let m = medium(random_grid(9), false);
    let lambda = all_live();
    let far = m.grid.local_to_world().transform_point3(Vec3::splat(100.0));
    let mut draws = 0;
    let mut r = || {
        draws += 1;
        0.5
    };
    assert_eq!(m.transmittance(far, Vec3::X, 50.0, &mut r, &lambda), SampledSpectrum::ONE);
    let ev = m.sample_distance(far, Vec3::X, 50.0, &mut r, &lambda);
    assert!(matches!(ev, DistanceSample::Pass { weight } if (0..N_SPECTRUM).all(|j| (weight[j] - 1.0).abs() < 1e-6)), "{ev:?}");
    // only the channel choice is drawn
    assert_eq!(draws, 1);
}

#[test]
fn bad_grids_are_rejected() {
    assert!(matches!(DensityGrid::new([2, 2, 2], &[1.0; 7], Mat4::IDENTITY), Err(GridError::Dims { .. })));
    assert!(matches!(DensityGrid::new([0, 2, 2], &[], Mat4::IDENTITY), Err(GridError::Dims { .. })));
    assert!(matches!(DensityGrid::new([1, 1, 1], &[1.0], Mat4::ZERO), Err(GridError::Transform)));
    // negative and NaN densities read as 0
    let g = DensityGrid::new([2, 1, 1], &[-3.0, f32::NAN], Mat4::IDENTITY).unwrap();
    assert_eq!(g.max_density(), 0.0);
}

