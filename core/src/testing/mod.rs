//! Statistical test helpers used by the core's own tests and by downstream crates:
//! χ² goodness-of-fit of direction samplers against their pdfs, and simple moments.

pub mod chi2;

use glam::{Vec2, Vec3};

/// The unit direction at cosθ = `mu` from +Z and azimuth `phi` from +X.
pub fn dir_mu(mu: f32, phi: f32) -> Vec3 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), mu)
}

/// A uniformly random direction in the upper hemisphere (kept just off the horizon).
pub fn random_upper(rng: &mut chi2::TestRng) -> Vec3 {
    let mut w = crate::math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
    w.z = w.z.abs().max(1e-4);
    w.normalize()
}

/// The world of `scene` at 4 × 4 pixels, which must build without a problem.
pub fn world_of(scene: &crate::scene::SceneDesc) -> crate::world::World {
    let mut problems = Vec::new();
    let w = crate::world::World::build(scene, &crate::render::RenderSettings { width: 4, height: 4, ..Default::default() }, &mut problems);
    assert!(problems.is_empty(), "{problems:?}");
    w
}
