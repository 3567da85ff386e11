//! Transforms that move over the shutter: any number of time samples, interpolated by
//! decomposition (scale and translation linearly, rotation by quaternion slerp) so that a
//! spinning object sweeps arcs, not chords.

use glam::{Mat4, Quat, Vec3};

#[derive(Clone, Debug, PartialEq)]
struct Key {
    time: f32,
    scale: Vec3,
    rot: Quat,
    trans: Vec3,
}

/// A possibly time-varying object-to-world transform.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionTransform(Repr);

/// A transform with one sample is held inline, with its inverse (a scene of a million
/// instances holds a million of them); one that moves keeps its samples on the heap.
#[derive(Clone, Debug, PartialEq)]
enum Repr {
    Static { m: Mat4, inv: Mat4 },
    Moving(Box<Moving>),
}

#[derive(Clone, Debug, PartialEq)]
struct Moving {
    keys: Vec<Key>,
    /// Matrices as given, for exact key times.
    mats: Vec<Mat4>,
    /// The given matrices could not be decomposed (shear): interpolate matrices linearly.
    linear: bool,
}

/// The decomposition of `m` into a key at `time`, and whether it gives `m` back (false: a
/// shear, which the decomposition loses).
fn decompose(m: &Mat4, time: f32) -> (Key, bool) {
    let (s, r, t) = m.to_scale_rotation_translation();
    let back = Mat4::from_scale_rotation_translation(s, r, t);
    let tol = 1e-4 * (1.0 + m.to_cols_array().iter().fold(0.0f32, |a, v| a.max(v.abs())));
    (Key { time, scale: s, rot: r, trans: t }, back.abs_diff_eq(*m, tol))
}

impl MotionTransform {
    pub fn new(mats: &[Mat4], times: &[f32]) -> Self {
        if mats.len() <= 1 {
            let m = mats.first().copied().unwrap_or(Mat4::IDENTITY);
            return MotionTransform(Repr::Static { m, inv: m.inverse() });
        }
        let mut linear = false;
        let keys = mats
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let (key, exact) = decompose(m, times.get(i).copied().unwrap_or(0.0));
                linear |= !exact;
                key
            })
            .collect();
        MotionTransform(Repr::Moving(Box::new(Moving { keys, mats: mats.to_vec(), linear })))
    }

    pub fn is_static(&self) -> bool {
        matches!(self.0, Repr::Static { .. })
    }

    /// Object-to-world at `time`.
    pub fn at(&self, time: f32) -> Mat4 {
        match &self.0 {
            Repr::Static { m, .. } => *m,
            Repr::Moving(mv) => mv.at(time),
        }
    }

    /// Where the transform only turns a surface's normals, not bends them: the first key's
    /// scale and, for each interval between keys that `shutter` reaches (or the interval the
    /// clamped shutter rests on), its end rotations (slerped between). None where matrices are
    /// interpolated linearly (shear) or the scale's proportions or signs change between keys
    /// (the normals' directions would then depend on more than the rotation).
    pub fn turning_segments(&self, shutter: (f32, f32)) -> Option<(Vec3, Vec<(Quat, Quat)>)> {
        let mv = match &self.0 {
            Repr::Static { m, .. } => {
                let (k, exact) = decompose(m, 0.0);
                return exact.then(|| (k.scale, vec![(k.rot, k.rot)]));
            }
            Repr::Moving(mv) => mv,
        };
        if mv.linear {
            return None;
        }
        let s0 = mv.keys[0].scale;
        let alike = |s: Vec3| {
            let k = s.length() / s0.length();
            (s - s0 * k).length() <= 1e-5 * s.length() && k > 0.0 && k.is_finite()
        };
        if !mv.keys.iter().all(|k| alike(k.scale)) {
            return None;
        }
        let (t0, t1) = (shutter.0.min(shutter.1), shutter.0.max(shutter.1));
        let (first, _) = mv.locate(t0);
        let (last, _) = mv.locate(t1);
        Some((s0, (first..=last).map(|i| (mv.keys[i].rot, mv.keys[i + 1].rot)).collect()))
    }

    /// A world ray mapped into object space (direction not renormalised: t is shared).
    #[inline]
    pub fn ray_to_local(&self, o: Vec3, d: Vec3, time: f32) -> (Vec3, Vec3) {
        let inv = match &self.0 {
            Repr::Static { inv, .. } => *inv,
            Repr::Moving(mv) => mv.at(time).inverse(),
        };
        (inv.transform_point3(o), inv.transform_vector3(d))
    }

    /// Matrices whose transformed bounds enclose the motion over `shutter`.
    pub fn bounding_matrices(&self, shutter: (f32, f32)) -> Vec<Mat4> {
        let mv = match &self.0 {
            Repr::Static { m, .. } => return vec![*m],
            Repr::Moving(mv) => mv,
        };
        // dense steps: rotations sweep arcs whose bounds the end keys alone miss. Each key
        // interval is cut into steps of at most 1/32 of it and of π/64 of turn, as few as
        // that allows (an interval that does not turn is its two ends), so thousands of keys
        // do not make millions of matrices.
        let mut out = vec![mv.at(shutter.0.min(mv.keys[0].time))];
        for (i, w) in mv.keys.windows(2).enumerate() {
            let turn = w[0].rot.angle_between(w[1].rot);
            let steps = if mv.linear { 1 } else { ((turn / (std::f32::consts::PI / 64.0)).ceil() as usize).clamp(1, 32) };
            for k in 1..=steps {
                let f = k as f32 / steps as f32;
                out.push(if k == steps { mv.mats[i + 1] } else { mv.at(w[0].time + (w[1].time - w[0].time) * f) });
            }
        }
        out
    }
}

impl Moving {
    /// Segment index and fraction for `time` (clamped to the samples' range).
    #[inline]
    fn locate(&self, time: f32) -> (usize, f32) {
        let n = self.keys.len();
        if time <= self.keys[0].time {
            return (0, 0.0);
        }
        if time >= self.keys[n - 1].time {
            return (n - 2, 1.0);
        }
        // the last key at or before `time` (bisection: thousands of keys are read per ray)
        let i = (self.keys.partition_point(|k| k.time <= time) - 1).min(n - 2);
        let (a, b) = (self.keys[i].time, self.keys[i + 1].time);
        (i, if b > a { (time - a) / (b - a) } else { 0.0 })
    }

    fn at(&self, time: f32) -> Mat4 {
        let (i, f) = self.locate(time);
        if f == 0.0 {
            return self.mats[i];
        }
        if f == 1.0 {
            return self.mats[i + 1];
        }
        if self.linear {
            return self.mats[i] * (1.0 - f) + self.mats[i + 1] * f;
        }
        let (a, b) = (&self.keys[i], &self.keys[i + 1]);
        let r = a.rot.slerp(b.rot, f);
        Mat4::from_scale_rotation_translation(a.scale.lerp(b.scale, f), r, a.trans.lerp(b.trans, f))
    }
}
