//! `volume` prims (UsdVolVolume with UsdVolOpenVDBAsset fields): which grid a volume reads,
//! the grids handed over by the front end (read once per file and field), and the core's
//! `VolumeDesc` a volume becomes at assembly.
//!
//! Attributes: `field:density` (Asset: the resolved VDB file), `field:density:fieldName`
//! (Token, default `density`), `field:density:fieldIndex` (Int, default 0: which of the grids
//! with that name), `field:density:transform` (Matrix: the field prim's placement relative to
//! the volume, identity by default). The prim's transform samples over the shutter move the
//! volume (transform motion blur; the grid's values themselves do not change). Other fields (`temperature`, ...) are accepted and not
//! used: Tide's volumes absorb and scatter, they do not emit.

use crate::value::{AttrStore, Problems};
use glam::Mat4;
use std::sync::Arc;
use tide_core::medium::grid::Bricks;
use tide_core::scene::{GridDesc, VolumeDesc};

/// The grid a volume reads.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeSpec {
    pub asset: String,
    pub field: String,
    pub index: i64,
    /// The field prim's space to the volume prim's.
    pub field_to_volume: Mat4,
}

/// Key of a loaded grid: (resolved file, field name, field index).
pub type GridKey = (String, String, i64);

/// A grid as the front end read it: its values over its active bounding box, in bricks (those
/// all zero not held), shared by every scene made with it.
#[derive(Clone, Debug, PartialEq)]
pub struct GridData {
    pub values: Arc<Bricks>,
    /// How many values were negative or not finite as read (held as 0).
    pub bad_values: usize,
    /// Grid-local (value [i, j, k] at (i, j, k)) to the volume prim's space.
    pub local_to_object: Mat4,
}

#[derive(Clone, Debug, PartialEq)]
pub enum GridState {
    Loaded(Arc<GridData>),
    Failed(String),
}

/// Reads which grid a volume uses; None (with a problem) when it names no density file.
pub fn volume_spec(s: &AttrStore, p: &mut Problems) -> Option<VolumeSpec> {
    let asset = s.str_opt("field:density").unwrap_or("").to_string();
    if asset.is_empty() {
        p.add("field:density", "the volume has no density field with a file; the volume is dropped");
        return None;
    }
    let field = s.str_opt("field:density:fieldName").filter(|f| !f.is_empty()).unwrap_or("density").to_string();
    let index = s.i64_or("field:density:fieldIndex", 0, p);
    let index = if index < 0 {
        p.add("field:density:fieldIndex", format!("{index} is negative; using 0"));
        0
    } else {
        index
    };
    let field_to_volume = s.matrix_samples("field:density:transform", p).first().map_or(Mat4::IDENTITY, |m| m.1.as_mat4());
    Some(VolumeSpec { asset, field, index, field_to_volume })
}

/// Checks a grid handed over by the front end. `index_to_object` is USD-style (row-major,
/// row vectors), as every Matrix value of the protocol.
pub fn grid_data(dims: [u32; 3], values: Vec<f32>, index_to_object: [f64; 16]) -> Result<GridData, String> {
    let n = dims.iter().map(|&d| d as usize).try_fold(1usize, |a, d| a.checked_mul(d));
    if dims.contains(&0) || n != Some(values.len()) {
        return Err(format!("grid of {}×{}×{} with {} values", dims[0], dims[1], dims[2], values.len()));
    }
    let local_to_object = grid_transform(index_to_object)?;
    let bad_values = values.iter().filter(|x| !x.is_finite() || **x < 0.0).count();
    let values = Bricks::from_dense(dims, &values).map_err(|e| e.to_string())?;
    Ok(GridData { values: Arc::new(values), bad_values, local_to_object })
}

/// [`grid_data`] from bricks as a reader hands them over ([`Bricks::from_coords`]): `coords`
/// the brick coordinates (three per brick) of the [`tide_core::medium::grid::BRICK`]³ bricks
/// whose values `pool` holds in turn.
pub fn grid_data_bricks(dims: [u32; 3], coords: &[u32], pool: Vec<f32>, index_to_object: [f64; 16]) -> Result<GridData, String> {
    let local_to_object = grid_transform(index_to_object)?;
    let bad_values = pool.iter().filter(|x| !x.is_finite() || **x < 0.0).count();
    let values = Bricks::from_coords(dims, coords, pool)?;
    Ok(GridData { values: Arc::new(values), bad_values, local_to_object })
}

fn grid_transform(index_to_object: [f64; 16]) -> Result<Mat4, String> {
    let m = Mat4::from_cols_array(&index_to_object.map(|v| v as f32));
    if !m.is_finite() || m.determinant().abs() < 1e-30 {
        return Err("the grid's transform is not finite and invertible".into());
    }
    Ok(m)
}

/// The core's volume for prim `path`: its grid placed by `object_to_world` (one key, or the
/// (shutter time, transform) keys of a volume that moves over the shutter), filled with medium
/// `medium`. Problems name the prim and `field:density` (grid missing or unreadable) or
/// `material` (no medium); the volume is then dropped.
pub fn volume_desc(path: &str, spec: &VolumeSpec, grid: Option<&GridState>, medium: Option<usize>, object_to_world: &[(f32, Mat4)], id: u32, p: &mut Problems) -> Option<VolumeDesc> {
    let data = match grid {
        Some(GridState::Loaded(d)) => d,
        Some(GridState::Failed(msg)) => {
            p.add("field:density", format!("cannot read grid '{}' of '{}': {msg}; the volume is dropped", spec.field, spec.asset));
            return None;
        }
        None => {
            p.add("field:density", format!("grid '{}' of '{}' was not loaded; the volume is dropped", spec.field, spec.asset));
            return None;
        }
    };
    let Some(medium) = medium else {
        p.add("material", "the bound material has no TideMedium volume; the volume is dropped");
        return None;
    };
    let grid = GridDesc { name: format!("{}:{}", spec.asset, spec.field), values: data.values.clone(), bad_values: data.bad_values, local_to_world: Mat4::IDENTITY };
    Some(placed_volume(path, grid, object_to_world, |m| m * spec.field_to_volume * data.local_to_object, medium, id))
}

/// A volume of `grid` whose local-to-world at an object-to-world key m is `place(m)`: still at
/// the first key, or moving through all of them.
pub fn placed_volume(path: &str, grid: GridDesc, object_to_world: &[(f32, Mat4)], place: impl Fn(Mat4) -> Mat4, medium: usize, id: u32) -> VolumeDesc {
    let rest = object_to_world.first().map_or(Mat4::IDENTITY, |k| k.1);
    VolumeDesc {
        name: path.to_string(),
        density: GridDesc { local_to_world: place(rest), ..grid },
        motion: if object_to_world.len() >= 2 { object_to_world.iter().map(|&(t, m)| (t, place(m))).collect() } else { Vec::new() },
        medium,
        id,
        visible_to_camera: true,
        casts_shadows: true,
    }
}

#[cfg(test)]
mod tests {
    use crate::{Delegate, Value};
    use glam::Vec3;

    fn tok(s: &str) -> Value {
        Value::Token(s.into())
    }

    /// A volume `/Fog` bound to a TideMedium material, translated by (0, 5, 0), reading
    /// `/f.vdb` field `density`.
    fn fog() -> Delegate {
        let mut d = Delegate::new();
        d.create_prim("material", "/M");
        d.set_attribute("/M", "volume", Value::Path("/M/V".into()), None);
        d.set_attribute("/M", "/M/V.info:id", tok("TideMedium"), None);
        d.set_attribute("/M", "/M/V.inputs:densityScale", Value::Float(2.0), None);
        d.create_prim("volume", "/Fog");
        let mut m = [0.0f64; 16];
        for k in 0..4 {
            m[5 * k] = 1.0;
        }
        m[13] = 5.0;
        d.set_attribute("/Fog", "transform", Value::Matrix(m), None);
        d.set_attribute("/Fog", "material", Value::Path("/M".into()), None);
        d.set_attribute("/Fog", "field:density", Value::Asset("/f.vdb".into()), None);
        d.set_attribute("/Fog", "field:density:fieldName", tok("density"), None);
        d
    }

    /// Index → object of a grid with voxels 0.5 wide whose first value sits at (1, 0, 0).
    fn voxel_half() -> [f64; 16] {
        let mut m = [0.0f64; 16];
        m[0] = 0.5;
        m[5] = 0.5;
        m[10] = 0.5;
        m[15] = 1.0;
        m[12] = 1.0;
        m
    }

    #[test]
    fn a_volume_reads_its_grid_and_the_bound_medium() {
        let mut d = fog();
        assert!(d.add_grid("/f.vdb", "density", 0, [2, 1, 1], vec![0.25, 1.0], voxel_half()));
        let p = d.commit_resources();
        assert!(p.is_empty(), "{p:?}");
        let s = d.scene();
        assert!(s.instances.is_empty());
        assert_eq!(s.volumes.len(), 1);
        let v = &s.volumes[0];
        assert_eq!(v.name, "/Fog");
        assert_eq!(v.density.values.dims(), [2, 1, 1]);
        assert_eq!(v.density.values.to_dense(), vec![0.25, 1.0]);
        // the medium is the TideMedium's, densityScale included
        assert_eq!(s.media[v.medium].scale, 2.0);
        // grid point (1, 0, 0): index → object (1.5, 0, 0), then the prim's +5 in y
        let w = v.density.local_to_world.transform_point3(Vec3::X);
        assert!((w - Vec3::new(1.5, 5.0, 0.0)).length() < 1e-6, "{w}");
    }

    #[test]
    fn a_missing_grid_or_medium_drops_the_volume_with_a_problem() {
        // not loaded at all
        let mut d = fog();
        let p = d.commit_resources();
        assert!(p.iter().any(|p| p.item == "/Fog" && p.attribute == "field:density"), "{p:?}");
        assert!(d.scene().volumes.is_empty());
        // the front end could not read it: the message is passed on; a later good grid
        // brings the volume back
        d.grid_failed("/f.vdb", "density", 0, "no such file");
        let p = d.commit_resources();
        assert!(p.iter().any(|p| p.item == "/Fog" && p.attribute == "field:density" && p.message.contains("no such file")), "{p:?}");
        assert!(d.scene().volumes.is_empty());
        d.add_grid("/f.vdb", "density", 0, [1, 1, 1], vec![1.0], voxel_half());
        d.commit_resources();
        assert_eq!(d.scene().volumes.len(), 1);
        // a grid with the wrong number of values
        assert!(!d.add_grid("/f.vdb", "density", 0, [2, 2, 1], vec![1.0], voxel_half()));
        let p = d.commit_resources();
        assert!(p.iter().any(|p| p.item == "/Fog" && p.attribute == "field:density"), "{p:?}");
        assert!(d.scene().volumes.is_empty());
        // no material with a medium
        let mut d = fog();
        d.add_grid("/f.vdb", "density", 0, [1, 1, 1], vec![1.0], voxel_half());
        d.clear_attribute("/Fog", "material");
        let p = d.commit_resources();
        assert!(p.iter().any(|p| p.item == "/Fog" && p.attribute == "material"), "{p:?}");
        assert!(d.scene().volumes.is_empty());
        // no density field at all
        let mut d = fog();
        d.clear_attribute("/Fog", "field:density");
        let p = d.commit_resources();
        assert!(p.iter().any(|p| p.item == "/Fog" && p.attribute == "field:density"), "{p:?}");
    }
}
