//! tide::ReadVdbGrid / LoadVdbFor: a volume's scalar grid read from an OpenVDB file as bricks
//! (its 8³ leaves, those of zeros left out) over its active bounding box, handed to the Rust
//! delegate (add_grid / grid_failed); tide::WriteVdbGrids writes small grids (for tests and
//! examples).
#pragma once

#include "rust/cxx.h"
#include "tide-bridge/src/lib.rs.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace tide {
class RenderParam;

/// A grid as the delegate takes it: value [i, j, k] at grid-local (i, j, k), placed by
/// `indexToObject` (USD-style: row-major, row vectors); the values in bricks of 8³: `coords`
/// the brick coordinates ((i, j, k) / 8, three per brick) of the bricks that hold anything,
/// whose values (x fastest within a brick) are written in turn into a Rust buffer of floats
/// that the delegate keeps as it is; the other bricks are zeros.
struct BrickGrid {
    uint32_t dims[3] = {0, 0, 0};
    std::vector<uint32_t> coords;
    std::optional<rust::Box<rs::TexelBuffer>> values;
    double indexToObject[16] = {};
};

/// Reads the `index`-th grid named `field` of the file at `path` (a float or double scalar
/// grid with a linear transform). False and `*error` for a missing file, a missing field or
/// a grid of another type.
bool ReadVdbGrid(const std::string& path, const std::string& field, int64_t index, BrickGrid* out, std::string* error);

/// Reads a grid once per (file, field, index) and hands it to Rust, or the reason it failed;
/// `reload` reads it again (its file changed on disk). True when the grid is held (read now
/// or before) and was readable.
bool LoadVdbFor(RenderParam& param, const std::string& asset, const std::string& field, int64_t index, bool reload = false);

/// A grid to write: `kind` "float", "double" or "vec3" (the value on every component),
/// `dims` values x fastest, the first at index `origin`, voxels `voxelSize` wide, then moved
/// by `translation`. Values of 0 are left inactive. Entries of one name write into one grid
/// (placed as the first of them says): blocks of a sparse grid.
struct VdbWriteGrid {
    std::string name;
    std::string kind;
    uint32_t dims[3] = {0, 0, 0};
    std::vector<float> values;
    double voxelSize = 1.0;
    double translation[3] = {0, 0, 0};
    int32_t origin[3] = {0, 0, 0};
};

bool WriteVdbGrids(const std::string& path, const std::vector<VdbWriteGrid>& grids, std::string* error);

}  // namespace tide
