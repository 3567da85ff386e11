//! Volumes in the world: each [`VolumeDesc`] becomes a density-grid medium
//! ([`crate::medium::GridMedium`]) and a closed box around the grid's support whose material is
//! a pure medium boundary ([`crate::world::SurfaceKind::MediumBoundary`]): it neither reflects
//! nor refracts, so a path crossing it goes straight on and only its interior stack changes
//! (the box's medium is pushed on entering and removed on leaving; the IOR is unchanged).
//!
//! Inside a box the volume's medium replaces whatever medium the path would otherwise be in
//! (water included); outside it, the usual nested-dielectric rules apply. Where boxes overlap,
//! the one entered last wins.

use crate::medium::{DensityGrid, GridError};
use crate::render::Problem;
use crate::scene::*;
use glam::{Mat4, Vec3};

/// A scene with its volumes turned into boxes, and what the world builder needs to finish
/// them: the density grid of each added medium and the materials that are medium boundaries.
pub struct Expanded {
    pub scene: SceneDesc,
    /// (index into `scene.media`, its grid)
    pub grids: Vec<(usize, DensityGrid)>,
    pub boundary_materials: Vec<usize>,
}

/// The 12 triangles of the box [lo, hi], wound counter-clockwise seen from outside (whatever
/// transform places it: a mirroring one keeps a mesh's front, see `World::surface`).
pub fn box_mesh(name: &str, lo: Vec3, hi: Vec3) -> MeshDesc {
    let positions: Vec<Vec3> = (0..8).map(|i| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z })).collect();
    // each face as a quad a, b, c, d counter-clockwise seen from outside
    let faces = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let mut indices = Vec::with_capacity(36);
    for [a, b, c, d] in faces {
        for t in [[a, b, c], [a, c, d]] {
            indices.extend(t);
        }
    }
    MeshDesc { name: name.into(), faces: Vec::new(), positions, indices, normals: None, uvs: None, uv_name: None, double_sided: false, motion: None, primvars: Vec::new(), origin: Default::default() }
}

/// Adds a box, a boundary material and a medium per volume. A volume whose grid or medium is
/// unusable is reported (item = the volume, attribute `field:density` or `material`) and left
/// out; the rest renders.
pub fn expand(scene: &SceneDesc, problems: &mut Vec<Problem>) -> Expanded {
    let mut s = scene.clone();
    s.volumes.clear();
    let mut grids = Vec::new();
    let mut boundary_materials = Vec::new();
    for v in &scene.volumes {
        let Some(base) = scene.media.get(v.medium) else {
            problems.push(Problem { item: v.name.clone(), attribute: "material".into(), message: format!("medium {} does not exist; volume dropped", v.medium) });
            continue;
        };
        let g = &v.density;
        let bad = g.bad_values;
        if bad > 0 {
            problems.push(Problem { item: v.name.clone(), attribute: "field:density".into(), message: format!("{bad} negative or non-finite density value(s) in {} read as 0", g.name) });
        }
        let (mats, times): (Vec<Mat4>, Vec<f32>) = if v.motion.len() >= 2 { (v.motion.iter().map(|k| k.1).collect(), v.motion.iter().map(|k| k.0).collect()) } else { (vec![g.local_to_world], vec![0.0]) };
        let grid = match DensityGrid::from_bricks(g.values.clone(), mats[0]).and_then(|grid| grid.with_motion(&mats, &times)) {
            Ok(grid) => grid,
            Err(e @ (GridError::Dims { .. } | GridError::Transform)) => {
                problems.push(Problem { item: v.name.clone(), attribute: "field:density".into(), message: format!("{}: {e}; volume dropped", g.name) });
                continue;
            }
        };
        if base.water.is_some() {
            problems.push(Problem {
                item: v.name.clone(),
                attribute: "material".into(),
                message: "natural-water inputs (jerlovType, chlorophyll, cdom, spm, profile) do not apply to a volume; its absorption and scattering are used".into(),
            });
        }
        let medium = s.media.len();
        s.media.push(MediumDesc { name: v.name.clone(), ..base.clone() });
        grids.push((medium, grid));
        let material = s.materials.len();
        // the surface is replaced by a medium boundary when the world is built
        s.materials.push(MaterialDesc { name: v.name.clone(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.0; 3]) }, interior_medium: Some(medium) });
        boundary_materials.push(material);
        let d = g.values.dims();
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
        let mesh = s.meshes.len();
        s.meshes.push(box_mesh(&v.name, lo, hi).into());
        // the box moves with the grid (the same keys, interpolated the same way)
        s.instances_mut().push(InstanceDesc {
            name: v.name.clone(),
            geometry: GeometryRef::Mesh(mesh),
            transforms: mats,
            times,
            material,
            id: v.id,
            visible_to_camera: v.visible_to_camera,
            casts_shadows: v.casts_shadows,
            primvar_row: None,
            index: None,
        });
    }
    Expanded { scene: s, grids, boundary_materials }
}
