//! Droplets converted to a medium (`TideDropletsAPI`, contract §5; SIGGRAPH 2023 course "the
//! path of water" §7.5). A cloud of small water droplets far from the camera is seen as its
//! aggregate: the droplets inside the cloud become a heterogeneous, purely scattering medium
//! on a voxel grid, those within `shell` of the cloud's boundary stay spheres (their silhouettes
//! are what the eye reads at the edge).
//!
//! Per voxel, from the droplets converted in it (Müller et al. 2016, as in the course):
//! R² = mean r², R³ = mean r³, f = Σ (4/3)πr³ / V (the volume fraction, capped at random close
//! packing), and
//!
//! σs = 1 / (λs + λv),  λs = (4 R³ / (3 R²)) (1 − f) / f,  λv = 1.44 R³ / R²,
//!
//! which tends to the geometric cross-section n·πr² = 3f / (4r) of dilute droplets. Water
//! droplets are taken as lossless (σa = 0). The phase function is a water sphere's in geometric
//! optics ([`droplet_phase`]): every impact parameter's reflection and its transmissions after
//! k internal reflections, weighted by Fresnel's terms — the forward lobe of refraction, the
//! primary and secondary rainbows and the glory side of backscatter.
//!
//! Voxel size and shell are lengths of the points' own space (the delegate turns the metres
//! they are authored in into those, with the stage's units and the prim's scale).

use crate::bsdf::fresnel_dielectric;
use crate::scene::{GridDesc, PhaseDesc, SpheresDesc};
use glam::{Mat4, Vec3};
use std::sync::OnceLock;

/// Densest volume fraction a voxel may reach (random close packing of spheres).
pub const MAX_FRACTION: f32 = 0.64;
/// Most voxels a cloud's grid may have.
pub const MAX_VOXELS: usize = 1 << 26;
/// Index of refraction of the droplets for the phase function.
pub const DROPLET_IOR: f32 = 1.333;

/// The scattering coefficient of droplets of mean squared and cubed radii `r2`, `r3` filling a
/// fraction `f` of space (0 when f ≤ 0).
pub fn sigma_s(r2: f32, r3: f32, f: f32) -> f32 {
    if !(f > 0.0 && r2 > 0.0 && r3 > 0.0) {
        return 0.0;
    }
    let f = f.min(MAX_FRACTION);
    let ratio = r3 / r2;
    let lambda_s = 4.0 * ratio / 3.0 * (1.0 - f) / f;
    let lambda_v = 1.44 * ratio;
    1.0 / (lambda_s + lambda_v)
}

/// A droplet cloud split into the spheres that stay and the medium the others become.
#[derive(Clone, Debug, PartialEq)]
pub struct DropletSplit {
    /// The droplets that stay spheres (all of them when none converts).
    pub spheres: SpheresDesc,
    /// σs (per metre) at voxel centres, placed in the points' object space by
    /// `local_to_world`; None when no droplet converts.
    pub grid: Option<GridDesc>,
    /// How many droplets became medium.
    pub converted: usize,
}

/// Splits `points` (droplet centres and radii; velocities and shape are kept for the spheres
/// that stay) on a grid of voxels `voxel` wide: droplets farther than `shell` inside the
/// cloud's boundary (the boundary of the voxels holding droplets) become medium.
pub fn split(points: &SpheresDesc, voxel: f32, shell: f32) -> Result<DropletSplit, String> {
    if !(voxel > 0.0 && voxel.is_finite()) {
        return Err(format!("a voxel size of {voxel} in the points' space is not positive and finite"));
    }
    let shell = if shell.is_finite() { shell.max(0.0) } else { 0.0 };
    let n = points.centers.len();
    let keep_all = || DropletSplit { spheres: points.clone(), grid: None, converted: 0 };
    if n == 0 {
        return Ok(keep_all());
    }
    let lo = points.centers.iter().fold(Vec3::splat(f32::INFINITY), |a, &c| a.min(c));
    let hi = points.centers.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, &c| a.max(c));
    // one empty layer of voxels on every side, so that the cloud's boundary is inside the grid;
    // counted in f64 first: a far-flung droplet must not wrap the integer sizes
    let cells = ((hi - lo) / voxel).floor();
    let span = cells.as_dvec3() + glam::DVec3::splat(3.0);
    if !(span.x * span.y * span.z <= MAX_VOXELS as f64) {
        return Err(format!("a {}×{}×{} grid is too large (at most {MAX_VOXELS} voxels)", span.x, span.y, span.z));
    }
    let inner = cells.as_uvec3() + glam::UVec3::ONE;
    let dims = [inner.x as usize + 2, inner.y as usize + 2, inner.z as usize + 2];
    let total = dims[0] * dims[1] * dims[2];
    let index = |c: Vec3| -> usize {
        let v = ((c - lo) / voxel).floor().as_uvec3().min(inner - glam::UVec3::ONE) + glam::UVec3::ONE;
        v.x as usize + dims[0] * (v.y as usize + dims[1] * v.z as usize)
    };
    let cell: Vec<usize> = points.centers.iter().map(|&c| index(c)).collect();
    let mut occupied = vec![false; total];
    for &k in &cell {
        occupied[k] = true;
    }
    let dist = distance_to_empty(&occupied, dims);
    // a droplet converts when the boundary (about half a voxel before the nearest empty
    // voxel's centre) is farther than the shell
    let converts: Vec<bool> = cell.iter().map(|&k| (dist[k] - 0.5) * voxel >= shell).collect();
    let converted = converts.iter().filter(|&&c| c).count();
    if converted == 0 {
        return Ok(keep_all());
    }
    let mut sums = vec![[0.0f64; 3]; total]; // Σr², Σr³, count
    for i in (0..n).filter(|&i| converts[i]) {
        let r = points.radii[i] as f64;
        let s = &mut sums[cell[i]];
        s[0] += r * r;
        s[1] += r * r * r;
        s[2] += 1.0;
    }
    let v_voxel = (voxel as f64).powi(3);
    let values: Vec<f32> = sums
        .iter()
        .map(|s| {
            if s[2] == 0.0 {
                return 0.0;
            }
            let f = 4.0 / 3.0 * std::f64::consts::PI * s[1] / v_voxel;
            sigma_s((s[0] / s[2]) as f32, (s[1] / s[2]) as f32, f as f32)
        })
        .collect();
    // grid point u = (i, j, k) is voxel (i, j, k)'s centre: lo + (u − ½)·voxel
    let local_to_world = Mat4::from_translation(lo - Vec3::splat(0.5 * voxel)) * Mat4::from_scale(Vec3::splat(voxel));
    let keep: Vec<usize> = (0..n).filter(|&i| !converts[i]).collect();
    let mut spheres = points.clone();
    spheres.centers = keep.iter().map(|&i| points.centers[i]).collect();
    spheres.radii = keep.iter().map(|&i| points.radii[i]).collect();
    spheres.velocities = points.velocities.as_ref().map(|v| keep.iter().map(|&i| v[i]).collect());
    Ok(DropletSplit {
        spheres,
        grid: Some(GridDesc::dense(format!("{} (droplets)", points.name), [dims[0] as u32, dims[1] as u32, dims[2] as u32], &values, local_to_world).map_err(|e| e.to_string())?),
        converted,
    })
}

/// Distance (in voxels, centre to centre) from every voxel to the nearest empty voxel: a
/// two-pass chamfer transform over the 26-neighbourhood with steps 1, √2, √3 (within 8% of the
/// Euclidean distance).
fn distance_to_empty(occupied: &[bool], dims: [usize; 3]) -> Vec<f32> {
    let [nx, ny, nz] = dims;
    let mut d: Vec<f32> = occupied.iter().map(|&o| if o { f32::INFINITY } else { 0.0 }).collect();
    let idx = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
    let steps: Vec<(i32, i32, i32, f32)> = {
        let mut v = Vec::new();
        for dz in -1..=1i32 {
            for dy in -1..=1i32 {
                for dx in -1..=1i32 {
                    // the neighbours visited before this voxel in the forward order
                    if (dz, dy, dx) < (0, 0, 0) {
                        v.push((dx, dy, dz, ((dx * dx + dy * dy + dz * dz) as f32).sqrt()));
                    }
                }
            }
        }
        v
    };
    let pass = |d: &mut Vec<f32>, sign: i32| {
        let order: Box<dyn Iterator<Item = usize>> = if sign > 0 { Box::new(0..nx * ny * nz) } else { Box::new((0..nx * ny * nz).rev()) };
        for k in order {
            if d[k] == 0.0 {
                continue;
            }
            let (x, y, z) = ((k % nx) as i32, ((k / nx) % ny) as i32, (k / (nx * ny)) as i32);
            let mut best = d[k];
            for &(dx, dy, dz, w) in &steps {
                let (a, b, c) = (x + sign * dx, y + sign * dy, z + sign * dz);
                if a < 0 || b < 0 || c < 0 || a >= nx as i32 || b >= ny as i32 || c >= nz as i32 {
                    continue;
                }
                best = best.min(d[idx(a as usize, b as usize, c as usize)] + w);
            }
            d[k] = best;
        }
    };
    pass(&mut d, 1);
    pass(&mut d, -1);
    d
}

/// Bins of the tabulated droplet phase function (over θ ∈ [0, π]).
const PHASE_BINS: usize = 360;

/// The phase function of a water droplet in geometric optics, tabulated over the scattering
/// angle θ (radians) as p(θ) per steradian (normalised to 1 over the sphere). For each impact
/// parameter b (stratified over the disc) the external reflection deviates light by π − 2θi
/// with weight F, the ray leaving after k internal reflections by 2(θi − θt) + k(π − 2θt)
/// with weight (1 − F)² F^k (F the same at every internal hit), k < 64.
pub fn droplet_phase_table() -> &'static (Vec<f32>, Vec<f32>) {
    static TABLE: OnceLock<(Vec<f32>, Vec<f32>)> = OnceLock::new();
    TABLE.get_or_init(|| {
        let n_b = 400_000;
        let mut hist = vec![0.0f64; PHASE_BINS];
        let bin_w = std::f64::consts::PI / PHASE_BINS as f64;
        let mut add = |deviation: f64, w: f64| {
            // fold the deviation onto [0, π]
            let t = deviation.rem_euclid(2.0 * std::f64::consts::PI);
            let theta = if t > std::f64::consts::PI { 2.0 * std::f64::consts::PI - t } else { t };
            hist[((theta / bin_w) as usize).min(PHASE_BINS - 1)] += w;
        };
        let eta = DROPLET_IOR as f64;
        for j in 0..n_b {
            // b uniform over the disc: b² uniform in [0, 1)
            let b = ((j as f64 + 0.5) / n_b as f64).sqrt();
            let ti = b.asin();
            let tt = (b / eta).asin();
            let f = fresnel_dielectric(ti.cos() as f32, DROPLET_IOR) as f64;
            add(std::f64::consts::PI - 2.0 * ti, f);
            let mut w = (1.0 - f) * (1.0 - f);
            for k in 0..64 {
                add(2.0 * (ti - tt) + k as f64 * (std::f64::consts::PI - 2.0 * tt), w);
                w *= f;
                if w < 1e-12 {
                    break;
                }
            }
        }
        let total: f64 = hist.iter().sum();
        let mut theta = Vec::with_capacity(PHASE_BINS);
        let mut value = Vec::with_capacity(PHASE_BINS);
        for (k, h) in hist.iter().enumerate() {
            let (a, b) = (k as f64 * bin_w, (k + 1) as f64 * bin_w);
            let solid = 2.0 * std::f64::consts::PI * (a.cos() - b.cos());
            theta.push(((k as f64 + 0.5) * bin_w) as f32);
            value.push((h / total / solid) as f32);
        }
        (theta, value)
    })
}

/// [`droplet_phase_table`] as a medium's phase function.
pub fn droplet_phase() -> PhaseDesc {
    let (theta, value) = droplet_phase_table();
    PhaseDesc::Tabulated { theta: theta.clone(), value: value.clone() }
}

#[cfg(test)]
mod tests;
