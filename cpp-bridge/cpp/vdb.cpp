//! Reading volumes' grids from OpenVDB files into dense arrays for the delegate, and writing
//! small grids.
#include "tide/vdb.h"

#include "tide/renderParam.h"

#include <openvdb/openvdb.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <sstream>

namespace tide {

namespace {

void InitOnce() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

/// Largest grid handed over: 2^28 values (1 GiB of floats).
constexpr uint64_t kMaxValues = uint64_t(1) << 28;

/// The grid's active voxels as a dense array over their bounding box, in `out`. The grid's
/// leaves are dropped as the array passes them (their values then held in it), so the grid
/// and its dense copy are not both held whole.
template <typename GridT>
bool Densify(GridT& grid, DenseGrid* out, std::string* error) {
    const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    openvdb::Coord lo(0, 0, 0);
    uint64_t dims[3] = {1, 1, 1};
    const bool empty = box.empty();
    if (!empty) {
        lo = box.min();
        // in 64 bits: an extent of 2^31 or more voxels does not fit Coord's ints
        for (int k = 0; k < 3; ++k) dims[k] = uint64_t(int64_t(box.max()[k]) - int64_t(box.min()[k]) + 1);
    }
    // the product, checked factor by factor so that it cannot wrap around
    bool fits = true;
    uint64_t count = 1;
    for (int k = 0; k < 3 && fits; ++k) {
        fits = dims[k] <= kMaxValues / count;
        if (fits) count *= dims[k];
    }
    if (!fits) {
        *error = "grid's active bounding box is " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) +
                 " x " + std::to_string(dims[2]) + " voxels (at most " + std::to_string(kMaxValues) + " in all)";
        return false;
    }
    // written a slice of constant k at a time into the memory the delegate keeps; a leaf whose
    // last slice is written is replaced by an inactive tile (its memory freed: the leaves of a
    // delay-loaded file are read as they are first touched, so the grid holds at most a layer
    // of leaves of it at a time)
    try {
        out->values.emplace(rs::new_texel_buffer(3, size_t(count)));
        auto& tree = grid.tree();
        using LeafT = typename GridT::TreeType::LeafNodeType;
        std::vector<openvdb::Coord> leaves;
        leaves.reserve(tree.leafCount());
        for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it->origin());
        std::sort(leaves.begin(), leaves.end(), [](const openvdb::Coord& a, const openvdb::Coord& b) { return a.z() < b.z(); });
        size_t dropped = 0;
        auto acc = grid.getConstAccessor();
        for (uint64_t k = 0; k < dims[2]; ++k) {
            rust::Slice<uint8_t> bytes = (*out->values)->grow(size_t(dims[0] * dims[1]));
            float* slice = reinterpret_cast<float*>(bytes.data());
            if (empty) continue;
            size_t n = 0;
            for (uint64_t j = 0; j < dims[1]; ++j)
                for (uint64_t i = 0; i < dims[0]; ++i)
                    slice[n++] = float(acc.getValue(lo.offsetBy(int(i), int(j), int(k))));
            const int64_t z = int64_t(lo.z()) + int64_t(k);
            bool any = false;
            while (dropped < leaves.size() && int64_t(leaves[dropped].z()) + int64_t(LeafT::DIM) - 1 <= z) {
                tree.addTile(1, leaves[dropped++], tree.background(), false);
                any = true;
            }
            // the accessor may hold a leaf just freed
            if (any) acc.clear();
        }
    } catch (const std::exception& e) {
        *error = "grid of " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                 std::to_string(dims[2]) + " voxels: " + e.what();
        return false;
    }
    for (int k = 0; k < 3; ++k) out->dims[k] = uint32_t(dims[k]);
    // the affine map from grid-local points (value [i, j, k] at index lo + (i, j, k))
    const openvdb::math::Transform& xf = grid.transform();
    const openvdb::Vec3d o = xf.indexToWorld(openvdb::Vec3d(lo.x(), lo.y(), lo.z()));
    const openvdb::Vec3d axes[3] = {xf.indexToWorld(openvdb::Vec3d(lo.x() + 1, lo.y(), lo.z())) - o,
                                    xf.indexToWorld(openvdb::Vec3d(lo.x(), lo.y() + 1, lo.z())) - o,
                                    xf.indexToWorld(openvdb::Vec3d(lo.x(), lo.y(), lo.z() + 1)) - o};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) out->indexToObject[4 * r + c] = axes[r][c];
        out->indexToObject[4 * r + 3] = 0.0;
    }
    for (int c = 0; c < 3; ++c) out->indexToObject[12 + c] = o[c];
    out->indexToObject[15] = 1.0;
    return true;
}

}  // namespace

bool ReadVdbGrid(const std::string& path, const std::string& field, int64_t index, DenseGrid* out, std::string* error) {
    auto fail = [&](const std::string& m) {
        if (error) *error = m;
        return false;
    };
    std::error_code ec;
    if (path.empty()) return fail("empty asset path");
    if (!std::filesystem::exists(path, ec)) return fail("no such file");
    try {
        InitOnce();
        // delay-loaded: of the file's grids only the one read has its voxels loaded (straight
        // from the file: no private copy of it is made, the grid is read at once)
        openvdb::io::File file(path);
        file.setCopyMaxBytes(0);
        file.open(/*delayLoad=*/true);
        openvdb::GridPtrVecPtr grids = file.getGrids();
        file.close();
        std::vector<openvdb::GridBase::Ptr> named;
        std::ostringstream names;
        for (const auto& g : *grids) {
            if (names.tellp() > 0) names << ", ";
            names << g->getName();
            if (g->getName() == field) named.push_back(g);
        }
        if (named.empty()) return fail("no grid named '" + field + "' (the file has: " + names.str() + ")");
        if (index < 0 || index >= int64_t(named.size()))
            return fail("fieldIndex " + std::to_string(index) + ": the file has " + std::to_string(named.size()) +
                        " grid(s) named '" + field + "'");
        const openvdb::GridBase::Ptr& base = named[size_t(index)];
        if (!base->transform().isLinear()) return fail("grid '" + field + "' has a non-linear (frustum) transform");
        std::string e;
        bool ok = false;
        if (auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) {
            ok = Densify(*fg, out, &e);
        } else if (auto dg = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) {
            ok = Densify(*dg, out, &e);
        } else {
            return fail("grid '" + field + "' is of type " + base->valueType() + ", not a float or double scalar grid");
        }
        return ok ? true : fail(e);
    } catch (const std::exception& ex) {
        return fail(std::string("cannot read VDB file: ") + ex.what());
    }
}

bool LoadVdbFor(RenderParam& param, const std::string& asset, const std::string& field, int64_t index, bool reload) {
    rs::Delegate& d = param.GetDelegate();
    if (!reload && d.has_grid(asset, field, index)) return true;
    DenseGrid grid;
    std::string error;
    if (!ReadVdbGrid(asset, field, index, &grid, &error)) {
        d.grid_failed(asset, field, index, error);
        return false;
    }
    return d.add_grid(asset, field, index, rust::Slice<const uint32_t>(grid.dims, 3), std::move(*grid.values),
                      rust::Slice<const double>(grid.indexToObject, 16));
}

bool WriteVdbGrids(const std::string& path, const std::vector<VdbWriteGrid>& grids, std::string* error) {
    try {
        InitOnce();
        openvdb::GridPtrVec out;
        for (const auto& w : grids) {
            const size_t n = size_t(w.dims[0]) * w.dims[1] * w.dims[2];
            if (n != w.values.size()) {
                if (error) *error = "grid '" + w.name + "': dims do not match the number of values";
                return false;
            }
            auto xf = openvdb::math::Transform::createLinearTransform(w.voxelSize);
            xf->postTranslate(openvdb::Vec3d(w.translation[0], w.translation[1], w.translation[2]));
            auto fill = [&](auto grid, auto make) {
                grid->setName(w.name);
                grid->setTransform(xf);
                grid->setGridClass(openvdb::GRID_FOG_VOLUME);
                auto acc = grid->getAccessor();
                size_t i = 0;
                for (uint32_t z = 0; z < w.dims[2]; ++z)
                    for (uint32_t y = 0; y < w.dims[1]; ++y)
                        for (uint32_t x = 0; x < w.dims[0]; ++x, ++i)
                            if (w.values[i] != 0.0f)
                                acc.setValue(openvdb::Coord(w.origin[0] + int(x), w.origin[1] + int(y), w.origin[2] + int(z)),
                                             make(w.values[i]));
                out.push_back(grid);
            };
            if (w.kind == "float") {
                fill(openvdb::FloatGrid::create(0.0f), [](float v) { return v; });
            } else if (w.kind == "double") {
                fill(openvdb::DoubleGrid::create(0.0), [](float v) { return double(v); });
            } else if (w.kind == "vec3") {
                fill(openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f)), [](float v) { return openvdb::Vec3s(v, v, v); });
            } else {
                if (error) *error = "grid '" + w.name + "': unknown kind '" + w.kind + "' (float, double or vec3)";
                return false;
            }
        }
        openvdb::io::File(path).write(out);
        return true;
    } catch (const std::exception& ex) {
        if (error) *error = std::string("cannot write VDB file: ") + ex.what();
        return false;
    }
}

}  // namespace tide
