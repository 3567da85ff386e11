//! Tests of droplets converted to a medium: the scattering coefficient's dilute limit, the
//! shell split and the grid's total cross-section, the phase function against an independent
//! 3-D ray tracer through a water sphere, and its rainbow.

use super::*;
use crate::bsdf::fresnel_dielectric;
use crate::testing::chi2::TestRng;

#[test]
fn sigma_s_tends_to_the_geometric_cross_section() {
    for r in [0.001f32, 0.01, 0.1] {
        let f = 1e-5;
        let s = sigma_s(r * r, r * r * r, f);
        let geometric = 3.0 * f / (4.0 * r);
        assert!((s / geometric - 1.0).abs() < 1e-3, "r {r}: {s} vs {geometric}");
    }
    // denser packs scatter more, but less than in proportion (the λv term)
    let r = 0.01;
    let (a, b) = (sigma_s(r * r, r * r * r, 0.1), sigma_s(r * r, r * r * r, 0.2));
    assert!(b > a && b < 2.0 * a, "{a} {b}");
    assert_eq!(sigma_s(r * r, r * r * r, 0.0), 0.0);
}

/// 20³ droplets on a lattice filling a 1 m cube.
fn cube_cloud(r: f32) -> SpheresDesc {
    let mut s = SpheresDesc { name: "/Spray".into(), ..Default::default() };
    for k in 0..20 {
        for j in 0..20 {
            for i in 0..20 {
                s.centers.push(Vec3::new(i as f32, j as f32, k as f32) * (1.0 / 19.0));
                s.radii.push(r);
            }
        }
    }
    s.velocities = Some(vec![Vec3::X; s.centers.len()]);
    s
}

#[test]
fn the_shell_stays_spheres_and_the_inside_becomes_medium() {
    let cloud = cube_cloud(0.005);
    let (voxel, shell) = (0.1, 0.2);
    let sp = split(&cloud, voxel, shell).unwrap();
    let grid = sp.grid.as_ref().expect("a grid");
    assert_eq!(sp.converted + sp.spheres.centers.len(), cloud.centers.len());
    assert_eq!(sp.spheres.velocities.as_ref().unwrap().len(), sp.spheres.centers.len());
    // distance of a droplet to the cloud's boundary (the unit cube's faces)
    let depth = |c: Vec3| c.min(Vec3::ONE - c).min_element();
    for c in &sp.spheres.centers {
        // kept: within the shell, up to the voxelisation (a voxel and the chamfer's 8%)
        assert!(depth(*c) < shell + 1.2 * voxel, "kept at depth {}", depth(*c));
    }
    let kept: std::collections::HashSet<[u32; 3]> = sp.spheres.centers.iter().map(|c| c.to_array().map(f32::to_bits)).collect();
    let converted: Vec<Vec3> = cloud.centers.iter().copied().filter(|c| !kept.contains(&c.to_array().map(f32::to_bits))).collect();
    assert_eq!(converted.len(), sp.converted);
    for c in &converted {
        assert!(depth(*c) > shell - 1.2 * voxel, "converted at depth {}", depth(*c));
    }
    assert!(sp.converted > 1000 && sp.spheres.centers.len() > 1000, "{} converted", sp.converted);
    // the grid's total cross-section ∫σs dV is the converted droplets' Σπr² (dilute: f ≈ 5%,
    // where λv lowers σs by about 1.44·f/(4/3)/(1 − f) ≈ 6%)
    let values = grid.values.to_dense();
    let total: f64 = values.iter().map(|&v| v as f64).sum::<f64>() * (voxel as f64).powi(3);
    let cross: f64 = sp.converted as f64 * std::f64::consts::PI * 0.005f64.powi(2);
    assert!((total / cross - 1.0).abs() < 0.1, "{total} vs {cross}");
    assert!(total < cross, "{total} vs {cross}");
    // every converted droplet sits in a voxel whose centre is within half a voxel, and that
    // voxel scatters
    let inv = grid.local_to_world.inverse();
    let [nx, ny, _] = grid.values.dims();
    for c in &converted {
        let u = inv.transform_point3(*c);
        let v = u.round();
        assert!((u - v).abs().max_element() <= 0.5 + 1e-4, "{u:?}");
        let k = v.x as usize + nx * (v.y as usize + ny * v.z as usize);
        assert!(values[k] > 0.0);
    }
}

// A droplet far from the others asks for a grid too large to hold: refused with the grid's
// size (its extent is 10¹¹ voxels per axis, which as 32-bit voxel counts would wrap to a
// small grid and index past its end).
#[test]
fn a_far_flung_droplet_asks_for_a_grid_too_large_and_is_refused() {
    let mut cloud = cube_cloud(0.01);
    cloud.centers[1] = Vec3::splat(1e9);
    let err = split(&cloud, 0.01, 0.0).unwrap_err();
    assert!(err.contains("too large") && err.starts_with("a 1000000"), "{err}");
    // two droplets: a cube of grid within the limit is made, one a few voxels wider is not
    let side = (MAX_VOXELS as f64).cbrt().floor() as f32;
    let pair = |d: f32| SpheresDesc { name: "/Pair".into(), centers: vec![Vec3::ZERO, Vec3::splat(d)], radii: vec![0.001; 2], ..Default::default() };
    assert!(split(&pair((side - 4.0) * 0.01), 0.01, 0.0).is_ok());
    assert!(split(&pair((side + 1.0) * 0.01), 0.01, 0.0).is_err());
}

#[test]
fn no_shell_converts_everything_and_a_thick_one_nothing() {
    let cloud = cube_cloud(0.005);
    let all = split(&cloud, 0.1, 0.0).unwrap();
    assert_eq!((all.converted, all.spheres.centers.len()), (cloud.centers.len(), 0));
    let none = split(&cloud, 0.1, 10.0).unwrap();
    assert_eq!(none.converted, 0);
    assert!(none.grid.is_none());
    assert_eq!(none.spheres, cloud);
    assert!(split(&cloud, 1e-5, 0.0).is_err(), "a 10⁵³ grid is refused");
    assert!(split(&cloud, 0.0, 0.0).is_err());
}

/// Traces photons through a water sphere in 3-D (ray–sphere hits, Snell's law in vector form,
/// Fresnel choices drawn at random): the distribution of the scattering angle over 10° bins
/// matches the tabulated phase function integrated over the same bins.
#[test]
fn the_phase_function_matches_a_ray_tracer_through_a_droplet() {
    let (theta, value) = droplet_phase_table();
    // normalised: ∫p dω = 1
    let bin_w = std::f64::consts::PI / theta.len() as f64;
    let solid = |k: usize| 2.0 * std::f64::consts::PI * ((k as f64 * bin_w).cos() - ((k + 1) as f64 * bin_w).cos());
    let norm: f64 = value.iter().enumerate().map(|(k, &p)| p as f64 * solid(k)).sum();
    assert!((norm - 1.0).abs() < 1e-4, "{norm}");
    const COARSE: usize = 18;
    let mut table = [0.0f64; COARSE];
    for (k, &p) in value.iter().enumerate() {
        table[k * COARSE / value.len()] += p as f64 * solid(k);
    }
    let mut rng = TestRng::new(42);
    let n = 200_000;
    let mut count = [0usize; COARSE];
    let eta = DROPLET_IOR;
    for _ in 0..n {
        // a ray along −Z at a uniform point of the unit disc
        let (a, b) = (rng.next_f32(), rng.next_f32());
        let r = a.sqrt();
        let phi = 2.0 * std::f32::consts::PI * b;
        let mut o = Vec3::new(r * phi.cos(), r * phi.sin(), 5.0);
        let mut d = -Vec3::Z;
        let mut inside = false;
        for _ in 0..200 {
            // next hit with the unit sphere
            let bq = o.dot(d);
            let c = o.length_squared() - 1.0;
            let disc = bq * bq - c;
            if disc < 0.0 {
                break;
            }
            let t = if inside { -bq + disc.sqrt() } else { -bq - disc.sqrt() };
            o += d * t;
            let mut nrm = o.normalize();
            if inside {
                nrm = -nrm;
            }
            let cos_i = -d.dot(nrm);
            let rel = if inside { 1.0 / eta } else { eta };
            let f = fresnel_dielectric(cos_i, rel);
            if rng.next_f32() < f {
                d = d + nrm * (2.0 * cos_i);
            } else {
                let k = 1.0 - (1.0 - cos_i * cos_i) / (rel * rel);
                d = d / rel + nrm * (cos_i / rel - k.max(0.0).sqrt());
                inside = !inside;
            }
            d = d.normalize();
            o += d * 1e-4;
            if !inside {
                break;
            }
        }
        let scatter = (-d.z).clamp(-1.0, 1.0).acos(); // angle from the incident direction −Z
        count[((scatter as f64 / std::f64::consts::PI * COARSE as f64) as usize).min(COARSE - 1)] += 1;
    }
    for k in 0..COARSE {
        let q = count[k] as f64 / n as f64;
        let sigma = (table[k] * (1.0 - table[k]) / n as f64).sqrt();
        assert!((q - table[k]).abs() < 5.0 * sigma + 1e-3, "bin {k}: tracer {q} vs table {}", table[k]);
    }
}

/// The primary rainbow: the deviation 2(θi − θt) + π − 2θt has its minimum at
/// cos θi = √((n² − 1)/3) (137.9° for n = 1.333), where the light piles up; just outside it,
/// Alexander's dark band.
#[test]
fn the_phase_function_has_its_rainbow() {
    let (theta, value) = droplet_phase_table();
    let n = DROPLET_IOR as f64;
    let ti = ((n * n - 1.0) / 3.0).sqrt().acos();
    let tt = (ti.sin() / n).asin();
    let bow = (2.0 * (ti - tt) + std::f64::consts::PI - 2.0 * tt).to_degrees();
    assert!((bow - 137.9).abs() < 0.1, "{bow}");
    let at = |deg: f64| {
        let k = theta.iter().position(|&t| (t as f64).to_degrees() > deg).unwrap();
        value[k]
    };
    assert!(at(bow + 0.3) > 3.0 * at(bow - 4.0), "{} vs {}", at(bow + 0.3), at(bow - 4.0));
    // mostly forward: the asymmetry parameter of a water sphere in geometric optics
    let bin_w = std::f64::consts::PI / theta.len() as f64;
    let g: f64 = theta
        .iter()
        .zip(value)
        .enumerate()
        .map(|(k, (&t, &p))| p as f64 * (t as f64).cos() * 2.0 * std::f64::consts::PI * ((k as f64 * bin_w).cos() - ((k + 1) as f64 * bin_w).cos()))
        .sum();
    assert!(g > 0.7 && g < 0.9, "g = {g}");
}
