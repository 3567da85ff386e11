//! Photon beams for volumetric caustics (god rays): the unscattered stretches of caustic photon
//! paths through scattering media, gathered along camera rays with a finite-chord "beam ×
//! beam" estimator (a 3D kernel, Jarosz et al. 2011) and the randomised width of Conty & Kulla
//! 2019 §6.2.
//!
//! # Estimator
//! A beam starts at `o` with flux Φ (per wavelength, stored as a [`Photon`] for its spectral
//! merging) and runs along unit `d` for `len`. Its flux is spread evenly over the disk of
//! radius `w` about its axis: a cylinder of density `1/(πw²)`, cut at its ends by the surfaces
//! the beam runs between (their tangent planes through the axis's ends, [`cap`]), so that the
//! cylinders of the beams that enter the water through one surface cover the water beneath it
//! evenly, right up to it. A camera ray `a + t·c`, t ∈ [0, t_max], in the same medium that
//! crosses the cylinder over the chord [t₀, t₁] receives
//!
//! `Φ(λ) · T_beam(s) · σs(x) · f_p(−c, −d) · T_cam(t) · (t₁ − t₀) / (πw²)`
//!
//! (times the inverse of the density of the point `x = a + t·c` drawn on the chord over its
//! uniform density, [`Chord::inv_pdf`]), `s` the light's depth into the beam at `x`: an
//! unbiased estimate of the integral of the cylinder's in-scattering along the chord. The
//! width is drawn once per camera ray, `w = w_p + (w_b − w_p)·√ξ` between the ray's pixel
//! footprint `w_p` and the beam's density-derived width `w_b`, which turns the estimator's
//! bias into noise (seed 002 App. A). Each realisation of the kernel integrates to one over
//! the beam's cross-section, so the estimate converges to the single-scattered radiance as
//! widths shrink.
//!
//! The chord is the ray's own overlap with the beam, so a beam nearly parallel to the ray
//! gives at most its length over πw². The 1D estimator (a ribbon of half-width `w` crossed at
//! the lines' closest points, `1/(2w sin θ)`) treats both as unbounded lines there: it grows
//! without bound as they turn parallel, and in forward-scattering water, where the phase
//! function peaks along the same direction, a camera path looking back along the sunlit
//! beams drew contributions 10⁵ times the typical (see `docs/caustics.md`, "The beam
//! estimator").
//!
//! # Storage and queries
//! Beams are cut into pieces of at most [`PIECE_LENGTH_WIDTHS`] widths; the eight-wide points
//! BVH of the ray tracer ([`crate::accel`]) holds the pieces' boxes grown by their beam's width. A query walks every piece whose box the
//! camera ray crosses; a beam contributes through the piece that holds its chord's drawn
//! point, so nothing is counted twice. Each piece carries its beam's line, length, width and
//! medium, stored in the BVH's leaf order, so the walk reads pieces in sequence and a beam's
//! own record only when the caller asks for it ([`Near::beam`], after its own tests of width
//! and medium); the beams themselves are stored in the order their first pieces take in the
//! leaves, so beams met together lie together.

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
    /// The beam's ends: the points `x` of its cylinder with `(x − o)·caps[0] ≥ 0` and
    /// `(x − o)·caps[1] ≤ len` ([`cap`]; `dir` for both: flat ends).
    pub caps: [Vec3; 2],
    /// Medium the beam travels in.
    pub medium: u32,
    /// The draw that kept the beam over the share it was kept at, uniform in [0, 1): keeping
    /// those below q keeps a random share q ([`BeamMap::thin`]).
    pub rank: f32,
}

/// Bytes a beam takes (its pieces and their BVH come on top: [`BeamMap::memory_bytes`]).
pub const BYTES_PER_BEAM: usize = std::mem::size_of::<Beam>();

/// The stretch [t0, t1] of a camera ray inside a beam's cylinder, and the point `x` drawn on it:
/// at `t` along the ray, with density `1 / inv_pdf` there. `s` is the light's depth into the
/// beam at `x`, `(x − o)·k₀` ([`Beam::caps`]): the distance along the beam from the start's
/// plane, which is where the light reaching `x` entered (not the projection of `x` on the axis,
/// which beside a wide beam's slanted start lies before it or deep beyond it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chord {
    pub t0: f32,
    pub t1: f32,
    pub t: f32,
    pub s: f32,
    pub inv_pdf: f32,
}

/// A point of [t0, t1] drawn with density ∝ e^{−k (t − t0)} from `u` in [0, 1), and the
/// inverse of that density there (k = 0: uniform). The rate is clamped so that the density
/// stays within e^{±60} over the stretch.
#[inline]
pub fn sample_exponential(t0: f32, t1: f32, k: f32, u: f32) -> (f32, f32) {
    let len = t1 - t0;
    let k = k.clamp(-60.0 / len, 60.0 / len);
    if !(len > 0.0) || !((k * len).abs() > 1e-4) {
        return (t0 + u * len, len);
    }
    // 1 − e^{−kL} (of the sign of k) and the inverse CDF, without cancellation
    let mass = -(-k * len).exp_m1();
    let x = (-(u * (-k * len).exp_m1()).ln_1p() / k).clamp(0.0, len);
    (t0 + x, mass / (k * (-k * x).exp()))
}

/// Largest tangent of the angle between a beam's end and the plane square to it ([`cap`]): a
/// cap reaches at most this many widths beyond the end of the axis.
pub const CAP_SLOPE: f32 = 1.732;

/// The end of a beam running along `d` that starts or stops on a surface of normal `n`: the
/// vector `k` (with `k·d = 1`) such that the points `x` of the surface's tangent plane through
/// the axis's end point `e` are those with `(x − e)·k = 0`. A beam's cylinder cut by the
/// surfaces it runs between, rather than square to its axis, covers the water beside a sloping
/// surface as evenly as the water beneath it: square ends leave a wedge of every beam's width
/// uncovered where beams enter through a surface oblique to them, and push as much of the beam
/// out of the water. Ends tilted by more than atan [`CAP_SLOPE`] (a beam grazing the surface)
/// are tilted that far; a zero normal gives the square end, `d`.
#[inline]
pub fn cap(d: Vec3, n: Vec3) -> Vec3 {
    let nd = n.dot(d);
    let m = n - d * nd;
    if !(nd.abs() > 0.0) || !m.is_finite() {
        return d;
    }
    let m = m / nd;
    let l = m.length();
    d + if l > CAP_SLOPE { m * (CAP_SLOPE / l) } else { m }
}

/// The stretch of the ray `a + t·c`, t ∈ [0, t_max], inside the cylinder of radius `w` about
/// the segment `o + s·d`, s ∈ [0, len] (unit directions), cut by its ends `k0`, `k1`
/// ([`Beam::caps`]; `d` for square ends): the ray's points within `w` of the beam's axis
/// between its two end planes. None when it is empty. A ray parallel to the beam and within
/// `w` of its axis runs inside along the beam's length.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn chord(a: Vec3, c: Vec3, t_max: f32, o: Vec3, d: Vec3, len: f32, w: f32, k0: Vec3, k1: Vec3) -> Option<(f32, f32)> {
    let r = a - o;
    // the parts of the ray's start and direction across the axis (through cross products,
    // exact where the two are nearly parallel)
    let p = d.cross(r.cross(d));
    let q = d.cross(c.cross(d));
    let (qq, pq, pp) = (q.length_squared(), p.dot(q), p.length_squared() - w * w);
    let (mut t0, mut t1) = (0.0f32, t_max);
    if qq > 1e-12 {
        let disc = pq * pq - qq * pp;
        if !(disc > 0.0) {
            return None;
        }
        let root = disc.sqrt();
        // the two roots without cancellation
        let k = -(pq + root.copysign(pq));
        let (x0, x1) = if k != 0.0 { (k / qq, pp / k) } else { (-root / qq, root / qq) };
        t0 = t0.max(x0.min(x1));
        t1 = t1.min(x0.max(x1));
    } else if !(pp < 0.0) {
        return None;
    }
    // the beam's ends: (r + t c)·k0 ≥ 0 and (r + t c)·k1 ≤ len
    for (k, lo, hi) in [(k0, 0.0, f32::INFINITY), (k1, f32::NEG_INFINITY, len)] {
        let (rk, ck) = (r.dot(k), c.dot(k));
        if ck.abs() > 1e-12 {
            let (y0, y1) = ((lo - rk) / ck, (hi - rk) / ck);
            t0 = t0.max(y0.min(y1));
            t1 = t1.min(y0.max(y1));
        } else if !(rk >= lo && rk <= hi) {
            return None;
        }
    }
    (t1 > t0).then_some((t0, t1))
}

/// Whether lines at closest approach `ap` are certainly farther apart than `w`, `reach` bounding
/// the distances from the camera ray's origin involved: `h`, computed from the lines' cross
/// product, loses accuracy as the lines turn parallel (an error of about 10⁻⁷ · reach / sin θ in
/// single precision), so the test allows for ten times that.
#[inline]
fn apart(ap: &Approach, w: f32, reach: f32) -> bool {
    ap.h > w * 1.0001 + 1e-6 * reach / ap.sin_theta
}

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
    /// The beam's length (the last piece, whose s1 it is, holds s = s1 too).
    len: f32,
    /// The beam's ends ([`Beam::caps`]).
    caps: [Vec3; 2],
}

impl Piece {
    /// Whether the piece answers for the place `s` along its beam.
    #[inline]
    fn holds(&self, s: f32) -> bool {
        s >= self.s0 && (s < self.s1 || (self.s1 == self.len && s <= self.s1))
    }
}

/// A beam met by a query: the kernel width drawn for it and its medium (read from the piece
/// that met it), and its record on demand.
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
                // the first and last pieces hold the ends' slanted caps too
                let reach = CAP_SLOPE * b.width;
                let p0 = b.photon.position + b.dir * if k == 0 { -reach } else { s0 };
                let p1 = b.photon.position + b.dir * if k + 1 == n as u32 { b.len + reach } else { s1 };
                // a little wider than the beam, so that a chord's point at the full width, up
                // to rounding, still lies in the box of the piece that holds it
                let g = Vec3A::splat(b.width * 1.001);
                bounds.push((Vec3A::from(p0.min(p1)) - g, Vec3A::from(p0.max(p1)) + g));
                pieces.push(Piece { o: b.photon.position, d: b.dir, s0, s1, width: b.width, beam: i as u32, medium: b.medium, len: b.len, caps: b.caps });
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

    /// Walks the beams near the camera ray `a + t·c`, t ∈ [0, t_max], each once:
    ///
    /// - `width(w_b, t)` gives the kernel width of a beam of width `w_b` (at most `w_b`) whose
    ///   footprint on the ray is read at `t` (its closest approach, or where its start projects
    ///   when it runs parallel to the ray);
    /// - `point(beam, t0, t1, c·k₀)` draws the beam's point on its chord [t0, t1] and the
    ///   inverse of its density there (a function of the beam, so that whichever piece asks
    ///   gets the same answer); `c·k₀` is the growth, per unit along the ray, of the light's
    ///   depth into the beam ([`Chord::s`]);
    /// - `f(beam, met, chord)` is called for every beam whose closest approach lies on the ray
    ///   and on the beam within the beam's own width (`met`, counted by the probe), and for
    ///   every beam the ray crosses at the kernel width (its `chord`).
    pub fn for_each_near(&self, a: Vec3, c: Vec3, t_max: f32, width: impl Fn(f32, f32) -> f32, point: impl Fn(u32, f32, f32, f32) -> (f32, f32), mut f: impl FnMut(Near<'_>, bool, Option<&Chord>)) {
        let Some(bvh) = &self.bvh else { return };
        bvh.traverse_slots(
            Vec3A::from(a),
            Vec3A::from(c),
            t_max.min(1e30),
            |k, _| {
                let p = &self.pieces[k];
                let ap = closest_approach(a, c, p.o, p.d);
                let reach = (p.o - a).length() + p.len;
                // lines farther apart than the beam's width (most pieces whose boxes the ray
                // crosses): neither a meeting nor a chord at any drawn width (the margin covers
                // the chord's own rounding)
                if ap.is_some_and(|ap| apart(&ap, p.width, reach)) {
                    return None;
                }
                // the piece that holds the closest point counts the meeting
                let met = ap.is_some_and(|ap| p.holds(ap.s) && ap.t >= 0.0 && ap.t <= t_max && ap.h < p.width);
                let at = ap.map_or((p.o - a).dot(c), |ap| ap.t).clamp(0.0, t_max);
                let w = width(p.width, at).min(p.width);
                // the piece that holds the chord's point answers for the beam's contribution
                let crosses = ap.is_none_or(|ap| !apart(&ap, w, reach));
                let chord = crosses.then(|| chord(a, c, t_max, p.o, p.d, p.len, w, p.caps[0], p.caps[1])).flatten().and_then(|(t0, t1)| {
                    // the light at a point of the chord entered the beam where the line along
                    // the beam through the point meets the start's plane: its depth into the
                    // beam is (x − o)·k0, which the point's draw follows
                    let ck = c.dot(p.caps[0]);
                    let (t, inv_pdf) = point(p.beam, t0, t1, ck);
                    let t = t.clamp(t0, t1);
                    let r = a - p.o + c * t;
                    let depth = r.dot(p.caps[0]).max(0.0);
                    p.holds(r.dot(p.d).clamp(0.0, p.len)).then_some(Chord { t0, t1, t, s: depth, inv_pdf })
                });
                if met || chord.is_some() {
                    f(Near { width: w, medium: p.medium, map: self, index: p.beam }, met, chord.as_ref());
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
    use crate::sampler::StreamRng;
    use crate::spectrum::{SampledSpectrum, SampledWavelengths};

    fn beam(o: Vec3, d: Vec3, len: f32, width: f32) -> Beam {
        let lambda = SampledWavelengths::sample_uniform(0.5);
        let photon = Photon::new(o, -d, d, SampledSpectrum::ONE, &lambda, 0).unwrap();
        Beam { photon, dir: d, len, width, caps: [d, d], medium: 0, rank: 0.5 }
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

    // The chord against points stepped along the ray: inside it exactly where a point lies
    // within the width of the axis and projects onto the beam; rays crossing, grazing and
    // parallel to the beam, starting inside it or stopping short of it.
    #[test]
    fn a_chord_is_where_the_ray_is_inside_the_beam() {
        let mut rng = crate::testing::chi2::TestRng::new(5);
        let mut v = || Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
        let (mut crossed, mut parallel) = (0, 0);
        for k in 0..400 {
            let (o, d) = (v(), v().normalize());
            let (len, w) = (0.5 + 2.0 * v().x.abs(), 0.05 + 0.3 * v().y.abs());
            // every fourth ray (nearly) parallel to the beam, from near its axis
            let c = if k % 4 == 0 { (d + v() * [0.0, 1e-4, 1e-2][k / 4 % 3]).normalize() } else { v().normalize() };
            let a = if k % 4 == 0 { o - c * v().x.abs() + v() * w * 0.8 } else { o + d * len * 0.5 + v() * 1.5 - c * 2.0 };
            let t_max = 1.0 + 4.0 * v().z.abs();
            let got = chord(a, c, t_max, o, d, len, w, d, d);
            let inside = |t: f32| {
                let x = a + c * t - o;
                let s = x.dot(d);
                (x - d * s).length() < w && (0.0..=len).contains(&s)
            };
            let n = 4000;
            for i in 0..=n {
                let t = t_max * i as f32 / n as f32;
                let within = got.is_some_and(|(t0, t1)| t > t0 && t < t1);
                let near_end = got.is_some_and(|(t0, t1)| (t - t0).abs() < 2e-3 || (t - t1).abs() < 2e-3);
                assert!(within == inside(t) || near_end, "ray {k}: t = {t}, chord {got:?}, inside {}", inside(t));
            }
            if let Some((t0, t1)) = got {
                assert!(0.0 <= t0 && t0 < t1 && t1 <= t_max);
                crossed += 1;
                parallel += (k % 4 == 0) as u32;
            }
        }
        assert!(crossed > 100 && parallel > 50, "{crossed} chords, {parallel} parallel");
    }

    // Points drawn on a stretch with density ∝ e^{−k t} (decaying, growing, flat, and a rate
    // past the clamp): a χ² test of their histogram against the density the inverse pdf
    // reports, and the inverse pdf against that density's normalisation.
    #[test]
    fn exponential_points_on_a_chord_follow_their_density() {
        let (t0, t1) = (0.5f32, 2.5f32);
        for k in [3.0f32, -2.0, 0.0, 1e-6, 80.0] {
            let kc = k.clamp(-60.0 / (t1 - t0), 60.0 / (t1 - t0));
            let density = |t: f64| if kc.abs() * (t1 - t0) > 1e-4 { kc as f64 * (-(kc as f64) * (t - t0 as f64)).exp() / (1.0 - (-(kc as f64) * (t1 - t0) as f64).exp()) } else { 1.0 / (t1 - t0) as f64 };
            let bins = 20;
            let mut hist = vec![0u64; bins];
            let n = 200_000;
            let mut rng = crate::testing::chi2::TestRng::new(9);
            for _ in 0..n {
                let (t, inv) = sample_exponential(t0, t1, k, rng.next_f32());
                assert!((t0..=t1).contains(&t));
                assert!(((1.0 / inv as f64) / density(t as f64) - 1.0).abs() < 1e-3, "k {k}: 1/{inv} against {}", density(t as f64));
                hist[(((t - t0) / (t1 - t0)) * bins as f32).min(bins as f32 - 1.0) as usize] += 1;
            }
            // expected counts by the density's integral over each bin
            let mut chi2 = 0.0;
            let mut used = 0;
            for (b, &h) in hist.iter().enumerate() {
                let (a, z) = (t0 as f64 + (t1 - t0) as f64 * b as f64 / bins as f64, t0 as f64 + (t1 - t0) as f64 * (b + 1) as f64 / bins as f64);
                let e = n as f64 * (0..100).map(|i| density(a + (z - a) * (i as f64 + 0.5) / 100.0)).sum::<f64>() / 100.0 * (z - a);
                if e >= 5.0 {
                    chi2 += (h as f64 - e).powi(2) / e;
                    used += 1;
                }
            }
            // the 0.1% quantile of χ² with used − 1 degrees of freedom (Wilson–Hilferty; 43.8
            // for 19), over the bins expecting at least five (a steep rate fills only the first)
            let dof = (used - 1) as f64;
            let q = dof * (1.0 - 2.0 / (9.0 * dof) + 3.09 * (2.0 / (9.0 * dof)).sqrt()).powi(3);
            assert!(used >= 3 && chi2 < q, "k {k}: χ² {chi2} over {used} bins (bound {q})");
        }
    }

    // The kernel integrates to one over the beam's cross-section: a sheet of parallel rays,
    // each weighing its chord over πw² by the area it stands for, sums to the beam's length,
    // at any angle to the beam, parallel included. (The 1D ribbon estimator sums to the same.)
    #[test]
    fn the_chord_kernel_integrates_to_the_beams_length() {
        let (o, d, len, w) = (Vec3::new(0.1, -0.2, 0.3), Vec3::X, 1.3f32, 0.1f32);
        for deg in [90.0f32, 30.0, 2.0, 0.0] {
            let th = deg.to_radians();
            let c = Vec3::new(th.cos(), th.sin(), 0.0);
            // the sheet's axes across c
            let (e1, e2) = (Vec3::new(-th.sin(), th.cos(), 0.0), Vec3::Z);
            // the sheet covers the beam's shadow along c: len sin θ + 2w by 2w
            let (half1, half2, n) = (0.5 * len * th.sin() + 1.2 * w, 1.2 * w, 600);
            let centre = o + d * (0.5 * len);
            let mut sum = 0.0f64;
            let cell = (2.0 * half1 / n as f32) * (2.0 * half2 / n as f32);
            for i in 0..n {
                for j in 0..n {
                    let y1 = -half1 + 2.0 * half1 * (i as f32 + 0.5) / n as f32;
                    let y2 = -half2 + 2.0 * half2 * (j as f32 + 0.5) / n as f32;
                    let a = centre + e1 * y1 + e2 * y2 - c * 10.0;
                    if let Some((t0, t1)) = chord(a, c, 20.0, o, d, len, w, d, d) {
                        sum += ((t1 - t0) / (std::f32::consts::PI * w * w) * cell) as f64;
                    }
                }
            }
            assert!((sum / len as f64 - 1.0).abs() < 0.01, "{deg}°: {sum} against {len}");
        }
    }

    /// Parallel beams on a fine square lattice across their direction, each running from a
    /// sloping surface where it enters the water to a floor sloping the other way, as sunlight
    /// refracted through a flat surface. Their cylinders, cut by those surfaces ([`cap`]),
    /// cover the water between them evenly: along any camera ray in the water, even one
    /// skimming just under a surface, the chord estimator summed over the beams (through the
    /// map's walk, each beam's chord at its full width, its point drawn uniformly) is the
    /// ray's length times the beams' density. Square ends leave the water along each surface
    /// short by up to half (the wedge beside every beam's start) and fail.
    #[test]
    fn beams_cut_by_their_surfaces_cover_the_water_evenly() {
        let d = Vec3::new(0.3, -1.0, 0.2).normalize();
        // the surface tilted 40° from square to the beams, the floor 25° the other way, 3 below
        let frame = crate::math::Frame::from_normal(d);
        let n_top = (-d * 40f32.to_radians().cos() + frame.s * 40f32.to_radians().sin()).normalize();
        let n_floor = (d * 25f32.to_radians().cos() + frame.t * 25f32.to_radians().sin()).normalize();
        let floor_at = d * 3.0;
        let (w, h) = (0.05f32, 0.01f32);
        for square in [false, true] {
            let mut beams = Vec::new();
            for i in -150..=150 {
                for j in -150..=150 {
                    let q = frame.s * (i as f32 * h) + frame.t * (j as f32 * h);
                    // where the axis q + s·d meets the surface (through the origin) and the floor
                    let s0 = -q.dot(n_top) / d.dot(n_top);
                    let s1 = (floor_at - q).dot(n_floor) / d.dot(n_floor);
                    let mut b = beam(q + d * s0, d, s1 - s0, w);
                    if !square {
                        // the surfaces' normals (either way round)
                        b.caps = [cap(d, n_top), cap(d, n_floor)];
                    }
                    beams.push(b);
                }
            }
            let map = BeamMap::build(beams);
            let mut rng = crate::testing::chi2::TestRng::new(11);
            let mut worst = 0.0f32;
            let mut dimmed_ratio = Vec::new();
            for k in 0..60 {
                // a ray in the water near the middle: just under the surface, just over the
                // floor, or anywhere between, in a random direction along the surface or not
                let u = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5);
                let along = match k % 3 {
                    0 => (u - n_top * u.dot(n_top)).normalize(),
                    1 => (u - n_floor * u.dot(n_floor)).normalize(),
                    _ => u.normalize(),
                };
                let base = frame.s * (rng.next_f32() - 0.5) * 0.4 + frame.t * (rng.next_f32() - 0.5) * 0.4;
                let a = match k % 3 {
                    0 => base - n_top * (base.dot(n_top) + 0.2 * w * rng.next_f32()),
                    1 => base + d * 3.0 + n_floor * ((floor_at - base - d * 3.0).dot(n_floor) - 0.2 * w * rng.next_f32()),
                    _ => base + d * (0.5 + 2.0 * rng.next_f32()),
                };
                // the ray's length within the water (the surface and the floor bound it)
                let mut len = 0.5f32;
                for (n, p) in [(n_top, Vec3::ZERO), (n_floor, floor_at)] {
                    // the water is on the side (x − p)·n < 0 of both
                    let (ap, cn) = ((a - p).dot(n), along.dot(n));
                    assert!(ap < 0.0, "ray {k} starts outside the water");
                    if cn > 0.0 {
                        len = len.min(-ap / cn);
                    }
                }
                // and the light dimmed by dense water (σ = 20 m⁻¹, 1/e in 1.7 widths) on its
                // way from the surface: the chord's points drawn at random, each weighed by
                // e^{−σ s} at its depth into the beam, against e^{−σ z} integrated along the ray,
                // z the depth below the surface along the beams (z = x·n / d·n)
                let (sigma, mut dimmed) = (20.0f64, 0.0f64);
                // (a beam's point is a function of the beam: every piece asking draws the same)
                let seed = rng.next_f32();
                let mut sum = 0.0f64;
                map.for_each_near(a, along, len, |wb, _| wb, |beam, t0, t1, _| (t0 + (t1 - t0) * StreamRng::new(seed, beam).next_f32(), t1 - t0), |_, _, ch| {
                    if let Some(ch) = ch {
                        sum += ch.inv_pdf as f64 / (std::f64::consts::PI * (w * w) as f64);
                        dimmed += ch.inv_pdf as f64 * (-sigma * ch.s as f64).exp() / (std::f64::consts::PI * (w * w) as f64);
                    }
                });
                let ratio = (sum * (h * h) as f64 / len as f64) as f32;
                worst = worst.max((ratio - 1.0).abs());
                if k % 3 == 0 {
                    let (z0, z1) = ((a.dot(n_top) / d.dot(n_top)) as f64, (along.dot(n_top) / d.dot(n_top)) as f64);
                    let want = if (sigma * z1 * len as f64).abs() > 1e-9 { (-sigma * z0).exp() * -(-sigma * z1 * len as f64).exp_m1() / (sigma * z1) } else { (-sigma * z0).exp() * len as f64 };
                    dimmed_ratio.push(dimmed * (h * h) as f64 / want);
                }
            }
            // the lattice is 5 cells to a width: its sums stay within 2% of the even density
            // (measured within 1.6%, the disks' lattice points counted along a short stretch;
            // square ends read 0.50–0.77 along the surfaces)
            if square {
                assert!(worst > 0.2, "square ends cover the water evenly? {worst}");
            } else {
                assert!(worst < 0.02, "cut beams deviate from the even density by {worst}");
                // (within 1.6% as undimmed; depths measured along the axis from its start
                // instead, each ray reads 0.87–0.97)
                assert!(dimmed_ratio.iter().all(|r| (r - 1.0).abs() < 0.02), "dimmed light along the surface: {dimmed_ratio:?}");
            }
        }
    }

    /// Rays nearly parallel to a beam (sin θ 10⁻⁴ to 10⁻², 20 m from its start), where the lines'
    /// distance from their cross product is off by more than the width: the walk's quick
    /// rejection of lines farther apart than the width must not drop a chord that runs inside
    /// the beam (its middle within the width of the axis, measured in double precision).
    #[test]
    fn nearly_parallel_rays_keep_their_chords() {
        let mut rng = crate::testing::chi2::TestRng::new(17);
        let mut v = || Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
        let (w, mut inside) = (0.02f32, 0);
        for k in 0..20000 {
            let d = v().normalize();
            let o = v() * 20.0;
            let tilt = [1e-4f32, 1e-3, 1e-2][k % 3];
            let c = (d + v() * tilt).normalize();
            // the ray starts 20 m before the beam, within 1.5 widths of its axis
            let a = o - c * 20.0 + v() * (1.5 * w);
            let b = beam(o, d, 10.0, w);
            let map = BeamMap::build(vec![b]);
            let mut found = None;
            map.for_each_near(a, c, 50.0, |wb, _| wb, |_, t0, t1, _| (0.5 * (t0 + t1), t1 - t0), |_, _, ch| {
                if let Some(ch) = ch {
                    assert!(found.replace((ch.t0, ch.t1)).is_none(), "a beam counted twice");
                }
            });
            let Some((t0, t1)) = chord(a, c, 50.0, o, d, 10.0, w, d, d) else { continue };
            let (a6, c6, o6, d6) = (a.as_dvec3(), c.as_dvec3(), o.as_dvec3(), d.as_dvec3());
            let x = a6 + c6 * (0.5 * (t0 + t1) as f64) - o6;
            if (x - d6 * x.dot(d6)).length() < 0.999 * w as f64 {
                inside += 1;
                assert_eq!(found, Some((t0, t1)), "ray {k}: a chord of {} widths dropped", (t1 - t0) / w);
            }
        }
        assert!(inside > 1000, "{inside} chords inside");
    }

    // Every beam within reach is found exactly once through the BVH, against a scan of all
    // beams, for random rays (pieces split long beams: a beam must not be reported twice):
    // once as met (its closest approach within its width) and once with its chord at the
    // kernel width, whose point is the one the scan draws.
    #[test]
    fn queries_find_each_beam_once() {
        let mut rng = crate::testing::chi2::TestRng::new(3);
        let mut v = || Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
        let mut beams = Vec::new();
        for k in 0..300 {
            // some beams along z, for rays along it to run parallel to
            let d = if k % 10 == 0 { Vec3::Z } else { v().normalize() };
            beams.push(beam(v() * 4.0, d, 0.5 + 5.0 * (v().x.abs()), 0.05 + 0.2 * v().y.abs()));
        }
        let map = BeamMap::build(beams.clone());
        let width = |wb: f32, t: f32| wb * (0.3 + 0.6 * (t * 0.37).fract());
        let point = |beam: u32, t0: f32, t1: f32, _| (t0 + (t1 - t0) * StreamRng::new(0.25, beam).next_f32(), t1 - t0);
        let mut chords = 0;
        for k in 0..100 {
            let (a, c) = (v() * 5.0, if k % 5 == 0 { Vec3::Z } else { v().normalize() });
            let t_max = 8.0;
            let (mut met, mut crossed) = (Vec::new(), Vec::new());
            map.for_each_near(a, c, t_max, width, point, |b, m, ch| {
                if m {
                    met.push(b.beam().photon.position);
                }
                if let Some(ch) = ch {
                    crossed.push((b.beam().photon.position, b.width, *ch));
                }
            });
            let (mut want_met, mut want_crossed) = (Vec::new(), Vec::new());
            for b in &beams {
                let ap = closest_approach(a, c, b.photon.position, b.dir);
                if ap.is_some_and(|ap| ap.s >= 0.0 && ap.s <= b.len && ap.t >= 0.0 && ap.t <= t_max && ap.h < b.width) {
                    want_met.push(b.photon.position);
                }
                let at = ap.map_or((b.photon.position - a).dot(c), |ap| ap.t).clamp(0.0, t_max);
                let w = width(b.width, at);
                if let Some((t0, t1)) = chord(a, c, t_max, b.photon.position, b.dir, b.len, w, b.caps[0], b.caps[1]) {
                    want_crossed.push((b.photon.position, w, t0, t1));
                }
            }
            assert_eq!(met.len(), want_met.len());
            for p in &want_met {
                assert_eq!(met.iter().filter(|q| *q == p).count(), 1);
            }
            assert_eq!(crossed.len(), want_crossed.len());
            for (p, w, t0, t1) in &want_crossed {
                let found: Vec<_> = crossed.iter().filter(|q| q.0 == *p).collect();
                assert_eq!(found.len(), 1);
                let (_, fw, ch) = found[0];
                assert_eq!((*fw, ch.t0, ch.t1), (*w, *t0, *t1));
                assert!(ch.t0 <= ch.t && ch.t <= ch.t1 && ch.inv_pdf == ch.t1 - ch.t0);
            }
            chords += crossed.len();
        }
        assert!(chords > 40, "{chords} chords");
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
        map.for_each_near(Vec3::new(0.5, -1.0, 0.05), Vec3::Y, 5.0, |wb, _| wb, |_, t0, t1, _| (0.5 * (t0 + t1), t1 - t0), |_, met, ch| {
            let ch = ch.expect("a chord");
            // across the beam 0.05 off its axis: √(0.1² − 0.05²) either side of y = 0
            let half = (0.1f32 * 0.1 - 0.05 * 0.05).sqrt();
            assert!(met && (ch.t0 - (1.0 - half)).abs() < 1e-5 && (ch.t1 - (1.0 + half)).abs() < 1e-5 && (ch.t - 1.0).abs() < 1e-5 && (ch.s - 0.5).abs() < 1e-5, "{ch:?}");
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
