//! Guided light tracing for god rays seen directly (seed 000 §5.5.2): while photons are traced,
//! every stretch of a photon path through the camera's own scattering medium after a caster
//! event is connected to the camera. A scattering point is drawn on the part of the stretch
//! inside the camera's frustum by equi-angular sampling about the camera (Kulla & Fajardo 2011:
//! the pdf cancels the 1/r² of the connection), the point is joined to the pinhole by a shadow
//! ray, and its radiance is splatted onto the pixels the pixel filter reaches.
//!
//! For a photon of power β entering the stretch at `o` along `d`, the scattering point
//! `x = o + t·d` (pdf p(t)) adds to pixel j
//!
//! ```text
//! β · T(o→x) · σs(x) · f_p(ω_c, −d) · T(x→c) · W_mis / (r² · p(t)) · dA/dω · F(raster(x) − c_j)
//! ```
//!
//! with ω_c the direction to the camera at distance r, `dA/dω` the raster area per steradian
//! ([`crate::camera::Camera::connect`]), F the pixel filter's density and `W_mis` the photon
//! side's approximate-MIS weight against the path tracer (the one beams use).
//!
//! Nothing is counted twice: light tracing takes the camera's first stretch (from the lens,
//! before any surface or event) in the media it covers, where camera paths then gather no
//! beams; every later stretch stays with the beams. Only pinhole cameras are connected to (with
//! depth of field the camera's first stretch keeps its beams).

use glam::{Vec2, Vec3};

use crate::filter::PixelFilter;
use crate::spectrum::{color, SampledSpectrum, SampledWavelengths};
use crate::world::World;

/// What one connection adds to one pixel (RGB, before the pass's photon weight), and the
/// photon's atlas cell and energy for the guiding signal (energy 0 on all but a connection's
/// first splat, so each connection is learned once).
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    pub pixel: u32,
    pub rgb: [f32; 3],
    pub cell: u32,
    pub energy: f32,
}

/// Equi-angular sampling of `t` in `[a, b]` on the line `o + t·d` (unit `d`) about the point
/// `c`: returns `(t, pdf(t))`, or None when the interval is empty.
pub fn sample_equiangular(o: Vec3, d: Vec3, a: f32, b: f32, c: Vec3, u: f32) -> Option<(f32, f32)> {
    if !(b > a) {
        return None;
    }
    let delta = (c - o).dot(d);
    let dist = (o + d * delta - c).length();
    if dist < 1e-6 * (b - a).max(1e-6) {
        // the point is on the line: uniform (the 1/r² left in the estimate is then the caller's)
        return Some((a + u * (b - a), 1.0 / (b - a)));
    }
    let th_a = ((a - delta) / dist).atan();
    let th_b = ((b - delta) / dist).atan();
    let th = th_a + u * (th_b - th_a);
    let t = (delta + dist * th.tan()).clamp(a, b);
    let pdf = equiangular_pdf(o, d, a, b, c, t);
    (pdf > 0.0 && pdf.is_finite()).then_some((t, pdf))
}

/// Density of [`sample_equiangular`] at `t`.
pub fn equiangular_pdf(o: Vec3, d: Vec3, a: f32, b: f32, c: Vec3, t: f32) -> f32 {
    if !(b > a) || t < a || t > b {
        return 0.0;
    }
    let delta = (c - o).dot(d);
    let dist = (o + d * delta - c).length();
    if dist < 1e-6 * (b - a).max(1e-6) {
        return 1.0 / (b - a);
    }
    let th_a = ((a - delta) / dist).atan();
    let th_b = ((b - delta) / dist).atan();
    let h = t - delta;
    dist / ((th_b - th_a) * (dist * dist + h * h))
}

/// Connections of photon stretches to the camera.
#[derive(Clone, Debug)]
pub struct LightTracer {
    /// Media whose photon stretches connect (the camera's medium, if it carries beams).
    media: Vec<bool>,
    filter: PixelFilter,
    width: u32,
    window: [u32; 4],
}

impl LightTracer {
    /// Light tracing in `camera_medium` when the camera is a pinhole and `beam_media` says the
    /// medium carries beams; None otherwise.
    pub fn new(world: &World, beam_media: &[bool], camera_medium: Option<usize>) -> Option<LightTracer> {
        let m = camera_medium?;
        if !world.camera.is_pinhole() || !beam_media.get(m).copied().unwrap_or(false) {
            return None;
        }
        let mut media = vec![false; beam_media.len()];
        media[m] = true;
        let (w, h) = (world.camera.width, world.camera.height);
        Some(LightTracer { media, filter: PixelFilter::default(), width: w, window: [0, 0, w, h] })
    }

    /// The image the splats land on: its pixel filter and data window.
    pub fn set_image(&mut self, filter: PixelFilter, window: [u32; 4]) {
        self.filter = filter;
        self.window = window;
    }

    /// Whether photon stretches in medium `m` connect to the camera (and so the camera's first
    /// stretch in it gathers no beams).
    #[inline]
    pub fn covers(&self, m: usize) -> bool {
        self.media.get(m).copied().unwrap_or(false)
    }

    /// Connects the photon stretch `o + t·d`, `t ∈ [0, len]`, in medium `m` to the camera;
    /// `beta` is the photon's power at `o`. `mis(p_b)` gives the photon side's MIS weight for a
    /// camera path that would have sampled the photon's direction with pdf `p_b`.
    #[allow(clippy::too_many_arguments)]
    pub fn connect(&self, world: &World, o: Vec3, d: Vec3, len: f32, m: usize, beta: SampledSpectrum, lambda: &SampledWavelengths, time: f32, cell: u32, u: f32, rng: &mut impl FnMut() -> f32, mis: impl Fn(f32) -> f32, out: &mut Vec<Splat>) {
        let cam = &world.camera;
        let r = 0.5 * self.filter.width;
        let [x0, y0, x1, y1] = self.window;
        let rect = [x0 as f32 - r, y0 as f32 - r, x1 as f32 + r, y1 as f32 + r];
        let Some((a, b)) = cam.frustum_interval(o, d, 0.0, len, time, rect) else { return };
        let c = cam.position(time);
        let Some((t, pdf)) = sample_equiangular(o, d, a, b, c, u) else { return };
        let x = o + d * t;
        let to_cam = c - x;
        let dist = to_cam.length();
        if !(dist > 0.0) {
            return;
        }
        let wc = to_cam / dist;
        let Some((raster, area_per_sr)) = cam.connect(x, time) else { return };
        let med = &world.media[m];
        let phase = med.phase(x);
        let fp = phase.eval(wc, -d);
        if !(fp > 0.0) {
            return;
        }
        // a phase function samples its own density: its pdf is `fp`
        let w_mis = mis(fp);
        if !(w_mis > 0.0) {
            return;
        }
        // nothing between the point and the lens: any surface (or area light) blocks, since a
        // camera path crossing one is no longer on its first stretch
        let shadow = crate::accel::Ray { o: x, d: wc, t_max: dist * (1.0 - 1e-4), time };
        if world.accel.intersect(&shadow).is_some() {
            return;
        }
        if world.light_bvh.any(&world.lights, x, wc, dist, time) {
            return;
        }
        let at = crate::medium::MediumAt::new(med, lambda);
        let tr = at.transmittance(o, d, t, rng) * at.transmittance(x, wc, dist, rng);
        let mut l = beta * tr * at.sigma_s_at(x) * (fp * w_mis / (dist * dist * pdf) * area_per_sr);
        if let Some(f) = cam.filter {
            l *= f.sample(lambda);
        }
        let rgb = color::xyz_to_output(color::to_xyz(l, lambda), world.cs);
        if !rgb.iter().all(|v| v.is_finite()) {
            return;
        }
        let energy = beta.average();
        let mut first = true;
        self.spread(raster, |pixel, wgt| {
            out.push(Splat { pixel, rgb: [rgb[0] * wgt, rgb[1] * wgt, rgb[2] * wgt], cell, energy: if first { energy } else { 0.0 } });
            first = false;
        });
    }

    /// Calls `f(pixel, weight)` for every pixel of the window whose filter reaches `raster`.
    fn spread(&self, raster: Vec2, mut f: impl FnMut(u32, f32)) {
        let r = 0.5 * self.filter.width;
        let [x0, y0, x1, y1] = self.window;
        let lo_x = ((raster.x - r - 0.5).ceil().max(x0 as f32)) as i64;
        let hi_x = ((raster.x + r - 0.5).floor().min(x1 as f32 - 1.0)) as i64;
        let lo_y = ((raster.y - r - 0.5).ceil().max(y0 as f32)) as i64;
        let hi_y = ((raster.y + r - 0.5).floor().min(y1 as f32 - 1.0)) as i64;
        for py in lo_y..=hi_y {
            let wy = self.filter.pdf(raster.y - (py as f32 + 0.5));
            if wy <= 0.0 {
                continue;
            }
            for px in lo_x..=hi_x {
                let wx = self.filter.pdf(raster.x - (px as f32 + 0.5));
                if wx > 0.0 {
                    f(py as u32 * self.width + px as u32, wx * wy);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{gamma_q, TestRng};

    #[test]
    fn equiangular_samples_follow_their_pdf() {
        // a segment passing 0.3 from the point, partly behind it: χ² over 50 bins in t
        let (o, d, c) = (Vec3::new(-2.0, 0.3, 0.0), Vec3::X, Vec3::ZERO);
        let (a, b) = (0.5, 3.5);
        let bins = 50;
        let n = 200_000;
        let mut counts = vec![0u32; bins];
        let mut rng = TestRng::new(17);
        for _ in 0..n {
            let (t, pdf) = sample_equiangular(o, d, a, b, c, rng.next_f32()).unwrap();
            assert!((pdf - equiangular_pdf(o, d, a, b, c, t)).abs() <= 1e-4 * pdf);
            counts[(((t - a) / (b - a)) * bins as f32).min(bins as f32 - 1.0) as usize] += 1;
        }
        let mut stat = 0.0;
        let mut total = 0.0;
        for (k, &cnt) in counts.iter().enumerate() {
            // expected mass of the bin by Simpson's rule on 32 intervals
            let (lo, hi) = (a + (b - a) * k as f32 / bins as f32, a + (b - a) * (k + 1) as f32 / bins as f32);
            let m = 32;
            let h = (hi - lo) as f64 / m as f64;
            let mut s = 0.0;
            for i in 0..=m {
                let w = if i == 0 || i == m { 1.0 } else if i % 2 == 1 { 4.0 } else { 2.0 };
                s += w * equiangular_pdf(o, d, a, b, c, lo + (i as f64 * h) as f32) as f64;
            }
            let p = s * h / 3.0;
            total += p;
            let e = p * n as f64;
            stat += (cnt as f64 - e).powi(2) / e;
        }
        assert!((total - 1.0).abs() < 1e-3, "∫pdf = {total}");
        let p = gamma_q((bins - 1) as f64 / 2.0, stat / 2.0);
        assert!(p > 1e-3, "χ² p = {p}");
    }

    #[test]
    fn splats_follow_the_pixel_filter_inside_the_window() {
        use crate::filter::FilterKind;
        let mut lt = LightTracer { media: vec![true], filter: PixelFilter::new(FilterKind::Box, 0.0).unwrap(), width: 10, window: [0, 0, 10, 8] };
        // box: the one pixel holding the point, weight 1
        let mut got = Vec::new();
        lt.spread(Vec2::new(3.7, 2.2), |p, w| got.push((p, w)));
        assert_eq!(got, vec![(2 * 10 + 3, 1.0)]);
        // Gaussian: the pixels within 1.5 px, weights = the filter's density at their centres,
        // which is what a camera sample landing at that point would have been drawn with
        lt.filter = PixelFilter::new(FilterKind::Gaussian, 0.0).unwrap();
        let p = Vec2::new(4.5, 4.5);
        let mut sum = 0.0;
        let mut n = 0;
        lt.spread(p, |i, w| {
            let (x, y) = ((i % 10) as f32 + 0.5, (i / 10) as f32 + 0.5);
            assert!((w - lt.filter.pdf(p.x - x) * lt.filter.pdf(p.y - y)).abs() < 1e-6);
            sum += w;
            n += 1;
        });
        // 3 × 3 pixels (centres at 0 and ±1 px); their weights sum to (Σ_k g(k))² with
        // g the truncated Gaussian of σ = 0.5: (0.79788 + 2 · 0.10798)² / 0.99730² = 1.03346
        // (the camera's own samples weigh pixels the same way, so the two sides agree)
        assert_eq!(n, 9);
        assert!((sum - 1.03346).abs() < 1e-4, "{sum}");
        // the window clips: a point at its corner reaches only pixels inside it
        lt.window = [2, 2, 6, 6];
        let mut pix = Vec::new();
        lt.spread(Vec2::new(2.1, 2.1), |i, _| pix.push(i));
        assert!(pix.iter().all(|&i| (2..6).contains(&(i % 10)) && (2..6).contains(&(i / 10))), "{pix:?}");
        assert!(!pix.is_empty());
    }

    #[test]
    fn equiangular_sampling_cancels_the_inverse_square() {
        // E[1/(r² p(t))] over samples = ∫ dt / r²: with the pdf ∝ 1/r², every sample gives the
        // same value (zero variance), here (θ_b − θ_a)/D
        let (o, d, c) = (Vec3::new(-1.0, 0.0, 0.5), Vec3::X, Vec3::ZERO);
        let exact = ((2.0f32 / 0.5).atan() - (-1.0f32 / 0.5).atan()) / 0.5;
        for u in [0.01, 0.3, 0.77, 0.99] {
            let (t, pdf) = sample_equiangular(o, d, 0.0, 3.0, c, u).unwrap();
            let r2 = (o + d * t - c).length_squared();
            assert!((1.0 / (r2 * pdf) - exact).abs() < 1e-4 * exact, "{u}");
        }
        assert!(sample_equiangular(o, d, 1.0, 1.0, c, 0.5).is_none());
    }
}
