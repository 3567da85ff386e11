//! Photon beams for volumetric caustics (god rays): the unscattered stretches of caustic photon
//! paths through scattering media, gathered along camera rays with the 1D "beam × beam"
//! estimator (Jarosz et al. 2011) and the randomised width of Conty & Kulla 2019 §6.2.
//!
//! # Estimator
//! A beam starts at `o` with flux Φ (per wavelength, stored as a [`Photon`] for its spectral
//! merging) and runs along unit `d` for `len`. A camera ray `a + t·c`, t ∈ [0, t_max], in the
//! same medium receives, for each beam whose line passes within the kernel width of the ray's,
//!
//! `Φ(λ) · T_beam(s) · σs(x) · f_p(−c, −d) · T_cam(t) · K(h) / sin θ`
//!
//! at the closest points `x = a + t·c ≈ o + s·d` of the two lines (distance `h`, angle θ);
//! `K(h) = 1/(2w)` for `h < w`, 0 beyond. The width is drawn once per camera ray,
//! `w = w_p + (w_b − w_p)·√ξ` between the ray's pixel footprint `w_p` and the beam's
//! density-derived width `w_b`, which makes the expected kernel a triangle (seed 002 App. A)
//! and turns the estimator's bias into noise. Each realisation of `K` integrates to one over
//! `h`, so the estimate converges to the single-scattered radiance as widths shrink.
//!
//! # Storage and queries
//! Beams are cut into pieces of at most [`PIECE_LENGTH_WIDTHS`] widths; the eight-wide points
//! BVH of the ray tracer ([`crate::accel`]) holds the pieces' boxes grown by their beam's width. A query walks every piece whose box the
//! camera ray crosses; a beam contributes through the piece that holds its closest point, so
//! nothing is counted twice. Each piece carries its beam's line, width and medium, stored in
//! the BVH's leaf order, so the walk reads pieces in sequence and a beam's own record only when
//! the caller asks for it ([`Near::beam`], after its own tests of width and medium); the beams
//! themselves are stored in the order their first pieces take in the leaves, so beams met
//! together lie together.

// `!(x < y)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::accel::{prefetch_lines, PointBvh};
use glam::{Vec3, Vec3A};

use super::photon_map::Photon;

/// Longest piece of a beam in the BVH, in beam widths.
pub const PIECE_LENGTH_WIDTHS: f32 = 16.0;
/// Most pieces one beam is cut into.
const MAX_PIECES: f32 = 64.0;

/// One photon beam.
#[derive(Clone, Copy, Debug)]
pub struct Beam {
    /// Start, flux at the start (spectral, as photons store it) and atlas cell.
    pub photon: Photon,
    pub dir: Vec3,
    pub len: f32,
    /// Density-derived half-width of the beam's kernel.
    pub width: f32,
    /// Medium the beam travels in.
    pub medium: u32,
    /// The draw that kept the beam over the share it was kept at, uniform in [0, 1): keeping
    /// those below q keeps a random share q ([`BeamMap::thin`]).
    pub rank: f32,
}

/// Bytes a beam takes (its pieces and their BVH come on top: [`BeamMap::memory_bytes`]).
pub const BYTES_PER_BEAM: usize = std::mem::size_of::<Beam>();

/// A beam's closest approach to a camera ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Approach {
    /// Distance along the camera ray and along the beam.
    pub t: f32,
    pub s: f32,
    /// Distance between the lines there.
    pub h: f32,
    pub sin_theta: f32,
}

/// The closest points of the line `a + t·c` and the beam's line `o + s·d` (unit directions);
/// None when they are (nearly) parallel.
#[inline]
pub fn closest_approach(a: Vec3, c: Vec3, o: Vec3, d: Vec3) -> Option<Approach> {
    let w = c.cross(d);
    let w2 = w.length_squared();
    if !(w2 > 1e-8) {
        return None;
    }
    let r = o - a;
    let t = r.cross(d).dot(w) / w2;
    let s = r.cross(c).dot(w) / w2;
    let sin_theta = w2.sqrt();
    let h = (r.dot(w) / sin_theta).abs();
    Some(Approach { t, s, h, sin_theta })
}

/// A piece of a beam as a query tests it: the beam's line, the stretch [s0, s1] of it this
/// piece answers for, the beam's width and index.
#[derive(Clone, Copy, Debug)]
struct Piece {
    o: Vec3,
    d: Vec3,
    s0: f32,
    s1: f32,
    width: f32,
    beam: u32,
    /// The beam's medium.
    medium: u32,
    /// Whether s1 is the beam's end (the piece then holds s = s1 too).
    closes: bool,
}

/// A beam met by a query: its width and medium (read from the piece that met it), and its
/// record on demand.
#[derive(Clone, Copy)]
pub struct Near<'a> {
    pub width: f32,
    pub medium: u32,
    map: &'a BeamMap,
    index: u32,
}

impl<'a> Near<'a> {
    /// The beam's record.
    #[inline]
    pub fn beam(&self) -> &'a Beam {
        &self.map.beams[self.index as usize]
    }
}

/// Beams of one pass with their BVH.
#[derive(Default)]
pub struct BeamMap {
    beams: Vec<Beam>,
    /// The pieces in the BVH's primitive order: piece `i` is primitive `i`.
    pieces: Vec<Piece>,
    bvh: Option<PointBvh>,
}

impl BeamMap {
    /// Builds the map; `beams` may come in any order from parallel tracing but must be in a
    /// deterministic order for a deterministic BVH (the caller's chunk order is).
    pub fn build(beams: Vec<Beam>) -> BeamMap {
        let mut pieces = Vec::new();
        let mut bounds = Vec::new();
        for (i, b) in beams.iter().enumerate() {
            if !(b.len > 0.0 && b.width > 0.0 && b.len.is_finite()) {
                continue;
            }
            let n = (b.len / (PIECE_LENGTH_WIDTHS * b.width)).ceil().clamp(1.0, MAX_PIECES);
            let step = b.len / n;
            for k in 0..n as u32 {
                let s0 = step * k as f32;
                let s1 = if k + 1 == n as u32 { b.len } else { step * (k + 1) as f32 };
                let p0 = b.photon.position + b.dir * s0;
                let p1 = b.photon.position + b.dir * s1;
                let g = Vec3A::splat(b.width);
                bounds.push((Vec3A::from(p0.min(p1)) - g, Vec3A::from(p0.max(p1)) + g));
                pieces.push(Piece { o: b.photon.position, d: b.dir, s0, s1, width: b.width, beam: i as u32, medium: b.medium, closes: s1 == b.len });
            }
        }
        if pieces.is_empty() {
            return BeamMap { beams, pieces, bvh: None };
        }
        let bvh = PointBvh::build(bounds.into_iter());
        let mut pieces: Vec<Piece> = bvh.ids().iter().map(|&k| pieces[k as usize]).collect();
        // the beams in the order of their first pieces in the leaves (those without a piece
        // last), permuted in place
        let mut slot = vec![u32::MAX; beams.len()];
        let mut from = Vec::with_capacity(beams.len());
        for p in &mut pieces {
            let k = &mut slot[p.beam as usize];
            if *k == u32::MAX {
                *k = from.len() as u32;
                from.push(p.beam);
            }
            p.beam = *k;
        }
        from.extend((0..beams.len() as u32).filter(|&i| slot[i as usize] == u32::MAX));
        let mut beams = beams;
        permute_in_place(&mut beams, &from);
        BeamMap { beams, pieces, bvh: Some(bvh) }
    }

    pub fn len(&self) -> usize {
        self.beams.len()
    }

    /// The map of a random share `q` of these beams: those whose rank is below `q`, their
    /// flux scaled by 1/q and their ranks by the same (so that thinning again is thinning the
    /// original by the product), their widths unchanged. The expected gathered radiance is the
    /// same, and the beams kept are those a pass tracing q times the share would keep.
    pub fn thin(self, q: f32) -> BeamMap {
        if !(q < 1.0) {
            return self;
        }
        let beams = self
            .beams
            .into_iter()
            .filter(|b| b.rank < q)
            .map(|mut b| {
                b.photon.scale_flux(1.0 / q);
                b.rank /= q;
                b
            })
            .collect();
        BeamMap::build(beams)
    }

    /// The beams, in the order the map keeps them.
    pub fn beams(&self) -> &[Beam] {
        &self.beams
    }

    pub fn is_empty(&self) -> bool {
        self.beams.is_empty()
    }

    /// Bytes held (beams, pieces, BVH nodes approximately).
    pub fn memory_bytes(&self) -> usize {
        self.beams.capacity() * BYTES_PER_BEAM + self.pieces.capacity() * std::mem::size_of::<Piece>() + self.bvh.as_ref().map_or(0, |b| b.bytes())
    }

    /// Calls `f(beam, approach)` for every beam whose closest approach to the camera ray
    /// `a + t·c`, t ∈ [0, t_max], lies on the ray and on the beam, within the beam's width of
    /// both lines: each beam once.
    pub fn for_each_near(&self, a: Vec3, c: Vec3, t_max: f32, mut f: impl FnMut(Near<'_>, &Approach)) {
        let Some(bvh) = &self.bvh else { return };
        bvh.traverse_slots(
            Vec3A::from(a),
            Vec3A::from(c),
            t_max.min(1e30),
            |k, _| {
                let p = &self.pieces[k];
                if let Some(ap) = closest_approach(a, c, p.o, p.d) {
                    // the piece that holds the closest point answers for its beam (the last
                    // piece closes its end)
                    let inside = ap.s >= p.s0 && (ap.s < p.s1 || (p.closes && ap.s <= p.s1));
                    if inside && ap.t >= 0.0 && ap.t <= t_max && ap.h < p.width {
                        f(Near { width: p.width, medium: p.medium, map: self, index: p.beam }, &ap);
                    }
                }
                None
            },
            |k| prefetch_lines(self.pieces.as_ptr().wrapping_add(k) as *const u8, 4 * std::mem::size_of::<Piece>()),
        );
    }
}

/// Reorders `v` so that `v[i]` becomes the old `v[from[i]]` (`from`: a permutation), moving
/// each element once and holding one aside per cycle.
fn permute_in_place<T: Copy>(v: &mut [T], from: &[u32]) {
    debug_assert_eq!(v.len(), from.len());
    let mut done = vec![false; v.len()];
    for start in 0..v.len() {
        if done[start] {
            continue;
        }
        let held = v[start];
        let mut i = start;
        loop {
            done[i] = true;
            let k = from[i] as usize;
            if k == start {
                v[i] = held;
                break;
            }
            v[i] = v[k];
            i = k;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::{SampledSpectrum, SampledWavelengths};

    fn beam(o: Vec3, d: Vec3, len: f32, width: f32) -> Beam {
        let lambda = SampledWavelengths::sample_uniform(0.5);
        let photon = Photon::new(o, -d, d, SampledSpectrum::ONE, &lambda, 0).unwrap();
        Beam { photon, dir: d, len, width, medium: 0, rank: 0.5 }
    }

    #[test]
    fn closest_approach_matches_brute_force() {
        let mut rng = crate::testing::chi2::TestRng::new(7);
        let mut v = || Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
        for _ in 0..200 {
            let (a, o) = (v() * 3.0, v() * 3.0);
            let (c, d) = (v().normalize(), v().normalize());
            let ap = closest_approach(a, c, o, d).unwrap();
            // brute force: the distance at the found parameters is minimal among neighbours
            let dist = |t: f32, s: f32| ((a + c * t) - (o + d * s)).length();
            let h0 = dist(ap.t, ap.s);
            assert!((h0 - ap.h).abs() < 1e-4, "{h0} vs {}", ap.h);
            for (dt, ds) in [(1e-2, 0.0), (-1e-2, 0.0), (0.0, 1e-2), (0.0, -1e-2)] {
                assert!(dist(ap.t + dt, ap.s + ds) >= h0 - 1e-5);
            }
            assert!((ap.sin_theta - c.cross(d).length()).abs() < 1e-5);
        }
    }

    // Every beam within reach is found exactly once through the BVH, against a scan of all
    // beams, for random rays (pieces split long beams: a beam must not be reported twice).
    #[test]
    fn queries_find_each_beam_once() {
        let mut rng = crate::testing::chi2::TestRng::new(3);
        let mut v = || Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
        let mut beams = Vec::new();
        for _ in 0..300 {
            beams.push(beam(v() * 4.0, v().normalize(), 0.5 + 5.0 * (v().x.abs()), 0.05 + 0.2 * v().y.abs()));
        }
        let map = BeamMap::build(beams.clone());
        for _ in 0..100 {
            let (a, c) = (v() * 5.0, v().normalize());
            let t_max = 8.0;
            let mut found = Vec::new();
            map.for_each_near(a, c, t_max, |b, _| found.push(b.beam().photon.position));
            let mut expect = Vec::new();
            for b in &beams {
                if let Some(ap) = closest_approach(a, c, b.photon.position, b.dir) {
                    if ap.s >= 0.0 && ap.s <= b.len && ap.t >= 0.0 && ap.t <= t_max && ap.h < b.width {
                        expect.push(b.photon.position);
                    }
                }
            }
            assert_eq!(found.len(), expect.len());
            for p in &expect {
                assert_eq!(found.iter().filter(|q| *q == p).count(), 1);
            }
        }
    }

    #[test]
    fn a_permutation_in_place_matches_a_copy() {
        let mut rng = crate::testing::chi2::TestRng::new(11);
        for n in [0usize, 1, 2, 7, 100] {
            let mut from: Vec<u32> = (0..n as u32).collect();
            for i in (1..n).rev() {
                from.swap(i, (rng.next_f32() * (i + 1) as f32) as usize % (i + 1));
            }
            let orig: Vec<u64> = (0..n as u64).map(|i| i * 7 + 3).collect();
            let mut v = orig.clone();
            permute_in_place(&mut v, &from);
            assert_eq!(v, from.iter().map(|&k| orig[k as usize]).collect::<Vec<_>>());
        }
    }

    // A map of one short beam (one piece: the BVH is a lone leaf) reports it once.
    #[test]
    fn a_lone_beam_is_found_once() {
        let map = BeamMap::build(vec![beam(Vec3::ZERO, Vec3::X, 1.0, 0.1)]);
        let mut found = 0;
        map.for_each_near(Vec3::new(0.5, -1.0, 0.05), Vec3::Y, 5.0, |_, ap| {
            assert!((ap.t - 1.0).abs() < 1e-5 && (ap.s - 0.5).abs() < 1e-5 && (ap.h - 0.05).abs() < 1e-5, "{ap:?}");
            found += 1;
        });
        assert_eq!(found, 1);
    }

    // The 1D kernel with a randomised width integrates to one across the beam: the expected
    // contribution, integrated over the offset h of a perpendicular camera ray, is Φ.
    #[test]
    fn randomised_width_kernel_integrates_to_one() {
        let wb = 0.3f32;
        let wp = 0.02f32;
        let n_h = 400;
        let n_xi = 4000;
        let mut integral = 0.0f64;
        for ih in 0..n_h {
            let h = (ih as f32 + 0.5) / n_h as f32 * wb;
            let mut e = 0.0f64;
            for k in 0..n_xi {
                let xi = (k as f32 + 0.5) / n_xi as f32;
                let w = wp + (wb - wp) * xi.sqrt();
                if h < w {
                    e += 1.0 / (2.0 * w as f64);
                }
            }
            integral += 2.0 * e / n_xi as f64 * (wb as f64 / n_h as f64);
        }
        // midpoint quadrature of a piecewise-smooth integrand: 0.5% is its error here
        assert!((integral - 1.0).abs() < 5e-3, "{integral}");
    }
}
