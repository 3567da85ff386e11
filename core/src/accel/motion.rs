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
pub struct MotionTransform {
    keys: Vec<Key>,
    /// Matrices as given, for the static case and exact key times.
    mats: Vec<Mat4>,
    inv: Vec<Mat4>,
    /// The given matrices could not be decomposed (shear): interpolate matrices linearly.
    linear: bool,
}

impl MotionTransform {
    pub fn new(mats: &[Mat4], times: &[f32]) -> Self {
        let mats: Vec<Mat4> = if mats.is_empty() { vec![Mat4::IDENTITY] } else { mats.to_vec() };
        let inv = mats.iter().map(|m| m.inverse()).collect();
        let mut linear = false;
        let keys = mats
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let (s, r, t) = m.to_scale_rotation_translation();
                let back = Mat4::from_scale_rotation_translation(s, r, t);
                let tol = 1e-4 * (1.0 + m.to_cols_array().iter().fold(0.0f32, |a, v| a.max(v.abs())));
                if !back.abs_diff_eq(*m, tol) {
                    linear = true;
                }
                Key { time: times.get(i).copied().unwrap_or(0.0), scale: s, rot: r, trans: t }
            })
            .collect();
        MotionTransform { keys, mats, inv, linear }
    }

    pub fn is_static(&self) -> bool {
        self.mats.len() == 1
    }

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

    /// Object-to-world at `time`.
    pub fn at(&self, time: f32) -> Mat4 {
        if self.is_static() {
            return self.mats[0];
        }
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

    /// Where the transform only turns a surface's normals, not bends them: the first key's
    /// scale and, for each interval between keys that `shutter` reaches (or the interval the
    /// clamped shutter rests on), its end rotations (slerped between). None where matrices are
    /// interpolated linearly (shear) or the scale's proportions or signs change between keys
    /// (the normals' directions would then depend on more than the rotation).
    pub fn turning_segments(&self, shutter: (f32, f32)) -> Option<(Vec3, Vec<(Quat, Quat)>)> {
        if self.linear {
            return None;
        }
        let s0 = self.keys[0].scale;
        let alike = |s: Vec3| {
            let k = s.length() / s0.length();
            (s - s0 * k).length() <= 1e-5 * s.length() && k > 0.0 && k.is_finite()
        };
        if !self.keys.iter().all(|k| alike(k.scale)) {
            return None;
        }
        if self.keys.len() == 1 {
            return Some((s0, vec![(self.keys[0].rot, self.keys[0].rot)]));
        }
        let (t0, t1) = (shutter.0.min(shutter.1), shutter.0.max(shutter.1));
        let (first, _) = self.locate(t0);
        let (last, _) = self.locate(t1);
        Some((s0, (first..=last).map(|i| (self.keys[i].rot, self.keys[i + 1].rot)).collect()))
    }

    /// A world ray mapped into object space (direction not renormalised: t is shared).
    #[inline]
    pub fn ray_to_local(&self, o: Vec3, d: Vec3, time: f32) -> (Vec3, Vec3) {
        let inv = if self.is_static() { self.inv[0] } else { self.at(time).inverse() };
        (inv.transform_point3(o), inv.transform_vector3(d))
    }

    /// Matrices whose transformed bounds enclose the motion over `shutter`.
    pub fn bounding_matrices(&self, shutter: (f32, f32)) -> Vec<Mat4> {
        if self.is_static() {
            return vec![self.mats[0]];
        }
        // dense steps: rotations sweep arcs whose bounds the end keys alone miss. Each key
        // interval is cut into steps of at most 1/32 of it and of π/64 of turn, as few as
        // that allows (an interval that does not turn is its two ends), so thousands of keys
        // do not make millions of matrices.
        let mut out = vec![self.at(shutter.0.min(self.keys[0].time))];
        for (i, w) in self.keys.windows(2).enumerate() {
            let turn = w[0].rot.angle_between(w[1].rot);
            let steps = if self.linear { 1 } else { ((turn / (std::f32::consts::PI / 64.0)).ceil() as usize).clamp(1, 32) };
            for k in 1..=steps {
                let f = k as f32 / steps as f32;
                out.push(if k == steps { self.mats[i + 1] } else { self.at(w[0].time + (w[1].time - w[0].time) * f) });
            }
        }
        out
    }
}
