//! The interior stack of nested dielectrics.

use crate::scene::*;
use crate::spectrum::SampledWavelengths;
use crate::world::World;
use glam::Vec3;

/// A unit cube about the origin of dispersive water (Quan–Fry).
fn dispersive_cube() -> World {
    let mut s = SceneDesc::default();
    let p = |i: usize| Vec3::new([-1.0, 1.0][i & 1], [-1.0, 1.0][(i >> 1) & 1], [-1.0, 1.0][(i >> 2) & 1]);
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let indices = quads.iter().flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect();
    s.meshes.push(MeshDesc { name: "/cube".into(), positions: (0..8).map(p).collect(), indices, ..Default::default() });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { dispersion: true, ..Default::default() }), interior_medium: None });
    s.instances.push(InstanceDesc { name: "/cube".into(), geometry: GeometryRef::Mesh(0), transforms: vec![glam::Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None });
    let mut problems = Vec::new();
    let w = World::build(&s, &crate::render::RenderSettings { width: 4, height: 4, ..Default::default() }, &mut problems);
    assert!(problems.is_empty(), "{problems:?}");
    w
}

#[test]
fn a_stack_found_once_takes_each_paths_index_of_dispersive_water() {
    let world = dispersive_cube();
    let found = super::initial_stack(&world, Vec3::ZERO, 0.0);
    assert_eq!(found.len(), 1);
    for nm in [400.0f32, 700.0] {
        let lambda = SampledWavelengths { lambda: [nm; crate::spectrum::N_SPECTRUM], pdf: [1.0; crate::spectrum::N_SPECTRUM] };
        let mut stack = found;
        stack.at_wavelengths(&world, &lambda);
        let want = crate::water::quan_fry_ior(0.0, 20.0, nm).unwrap();
        assert!((stack.ior() - want).abs() < 1e-5, "{nm} nm: {} vs {want}", stack.ior());
    }
}
