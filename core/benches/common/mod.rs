//! What the benchmarks share.

use glam::Vec3;

/// A small deterministic generator (xorshift64*), uniform in [0, 1).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
    }

    /// A direction uniform on the sphere.
    pub fn dir(&mut self) -> Vec3 {
        let z = 2.0 * self.next() - 1.0;
        let p = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * p.cos(), r * p.sin(), z)
    }
}
