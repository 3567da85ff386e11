//! The interior stack of nested dielectrics.

use crate::scene::*;
use crate::spectrum::SampledWavelengths;
use crate::world::World;
use glam::Vec3;

/// A unit cube about the origin of dispersive water (Quan–Fry).
fn dispersive_cube() -> World {
    let mut s = SceneDesc::default();
    s.meshes.push(crate::volume::box_mesh("/cube", -Vec3::ONE, Vec3::ONE).into());
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { dispersion: true, ..Default::default() }), interior_medium: None });
    s.instances_mut().push(InstanceDesc { name: "/cube".into(), geometry: GeometryRef::Mesh(0), transforms: vec![glam::Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None });
    crate::testing::world_of(&s)
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
