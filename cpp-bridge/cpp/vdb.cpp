//! Reading volumes' grids from OpenVDB files into bricks (their 8³ leaves) for the delegate,
//! and writing small grids.
#include "tide/vdb.h"

#include "tide/renderParam.h"

#include <openvdb/openvdb.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

namespace tide {

namespace {

void InitOnce() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

/// Most bricks handed over (their index is a 32-bit number).
constexpr uint64_t kMaxBricks = uint64_t(UINT32_MAX) - 1;

/// The grid's values in bricks of 8³, its leaves': over the active voxels' bounding box with
/// its low corner moved down to a leaf's origin, so that each leaf is one brick, handed over
/// as the stored bricks' coordinates and values (the box's size costs nothing). A leaf of
/// zeros is left out, an active tile becomes bricks of its value. Each leaf is dropped from the
/// grid once copied (the leaves of a delay-loaded file are read as they are first touched, so
/// the grid never holds them all at once).
template <typename GridT>
bool Brickify(GridT& grid, BrickGrid* out, std::string* error) {
    using TreeT = typename GridT::TreeType;
    using LeafT = typename TreeT::LeafNodeType;
    static_assert(LeafT::DIM == 8, "bricks are OpenVDB's 8^3 leaves");
    constexpr int B = 8;
    const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    const bool empty = box.empty();
    openvdb::Coord lo(0, 0, 0);
    uint64_t dims[3] = {1, 1, 1};
    if (!empty) {
        // leaf origins are multiples of 8 (two's complement: ~7 rounds negatives down too)
        lo = openvdb::Coord(box.min().x() & ~(B - 1), box.min().y() & ~(B - 1), box.min().z() & ~(B - 1));
        // in 64 bits: an extent of 2^31 or more voxels does not fit Coord's ints
        for (int k = 0; k < 3; ++k) dims[k] = uint64_t(int64_t(box.max()[k]) - int64_t(lo[k]) + 1);
    }
    if (std::max({dims[0], dims[1], dims[2]}) > UINT32_MAX) {
        *error = "grid's active bounding box is " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                 std::to_string(dims[2]) + " voxels (at most " + std::to_string(UINT32_MAX) + " along an axis)";
        return false;
    }
    // the brick of a voxel (its coordinates from the box's low corner), false outside the box
    auto brickOf = [&](const openvdb::Coord& c, uint32_t b[3]) {
        for (int k = 0; k < 3; ++k) {
            const int64_t i = int64_t(c[k]) - int64_t(lo[k]);
            if (i < 0 || uint64_t(i) >= dims[k]) return false;
            b[k] = uint32_t(i / B);
        }
        return true;
    };
    auto& tree = grid.tree();
    std::vector<openvdb::Coord> leaves;
    std::vector<std::pair<openvdb::Coord, float>> tiles;  // (brick origin, value) of active tiles
    if (!empty) {
        leaves.reserve(tree.leafCount());
        uint32_t b[3];
        for (auto it = tree.cbeginLeaf(); it; ++it)
            if (brickOf(it->origin(), b)) leaves.push_back(it->origin());
        for (auto it = tree.cbeginValueOn(); it; ++it) {
            if (!it.isTileValue()) continue;
            const float v = float(*it);
            if (!(v != 0.0f)) continue;
            openvdb::CoordBBox tb;
            it.getBoundingBox(tb);
            tb.intersect(box);
            if (tb.empty()) continue;
            for (int z = tb.min().z() & ~(B - 1); z <= tb.max().z(); z += B)
                for (int y = tb.min().y() & ~(B - 1); y <= tb.max().y(); y += B)
                    for (int x = tb.min().x() & ~(B - 1); x <= tb.max().x(); x += B) {
                        const openvdb::Coord o(std::max(x, lo.x()), std::max(y, lo.y()), std::max(z, lo.z()));
                        if (brickOf(o, b)) tiles.emplace_back(o, v);
                    }
        }
    }
    const uint64_t stored = leaves.size() + tiles.size();
    if (stored > kMaxBricks) {
        *error = "grid holds " + std::to_string(stored) + " bricks of 8^3 values (at most " + std::to_string(kMaxBricks) + ")";
        return false;
    }
    try {
        out->coords.clear();
        out->coords.reserve(size_t(stored) * 3);
        out->values.emplace(rs::new_texel_buffer(3, size_t(stored) * B * B * B));
        // the bricks handed over (a brick is given once)
        std::set<std::pair<uint64_t, uint32_t>> given;
        auto put = [&](const openvdb::Coord& at, auto&& value) {
            uint32_t b[3];
            if (!brickOf(at, b)) return;
            if (!given.emplace(uint64_t(b[0]) | uint64_t(b[1]) << 32, b[2]).second) return;
            rust::Slice<uint8_t> bytes = (*out->values)->grow(B * B * B);
            float* v = reinterpret_cast<float*>(bytes.data());
            for (int z = 0; z < B; ++z)
                for (int y = 0; y < B; ++y)
                    for (int x = 0; x < B; ++x) *v++ = value(x, y, z);
            out->coords.insert(out->coords.end(), {b[0], b[1], b[2]});
        };
        for (const openvdb::Coord& o : leaves) {
            if (const LeafT* leaf = tree.probeConstLeaf(o)) {
                bool any = false;
                for (auto it = leaf->cbeginValueAll(); it && !any; ++it) any = float(*it) != 0.0f;
                if (any)
                    put(o, [&](int x, int y, int z) { return float(leaf->getValue(LeafT::coordToOffset(openvdb::Coord(o.x() + x, o.y() + y, o.z() + z)))); });
            }
            // its memory freed: replaced by an inactive tile of the background
            tree.addTile(1, o, tree.background(), false);
        }
        for (const auto& [o, value] : tiles) put(o, [v = value](int, int, int) { return v; });
    } catch (const std::exception& e) {
        *error = "grid of " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " + std::to_string(dims[2]) +
                 " voxels in " + std::to_string(stored) + " bricks: " + e.what();
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

bool ReadVdbGrid(const std::string& path, const std::string& field, int64_t index, BrickGrid* out, std::string* error) {
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
            ok = Brickify(*fg, out, &e);
        } else if (auto dg = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) {
            ok = Brickify(*dg, out, &e);
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
    BrickGrid grid;
    std::string error;
    if (!ReadVdbGrid(asset, field, index, &grid, &error)) {
        d.grid_failed(asset, field, index, error);
        return false;
    }
    return d.add_grid(asset, field, index, rust::Slice<const uint32_t>(grid.dims, 3),
                      rust::Slice<const uint32_t>(grid.coords.data(), grid.coords.size()), std::move(*grid.values),
                      rust::Slice<const double>(grid.indexToObject, 16));
}

bool WriteVdbGrids(const std::string& path, const std::vector<VdbWriteGrid>& grids, std::string* error) {
    try {
        InitOnce();
        openvdb::GridPtrVec out;
        // entries of one name write into one grid (with the first one's transform)
        std::map<std::string, openvdb::GridBase::Ptr> byName;
        for (const auto& w : grids) {
            const size_t n = size_t(w.dims[0]) * w.dims[1] * w.dims[2];
            if (n != w.values.size()) {
                if (error) *error = "grid '" + w.name + "': dims do not match the number of values";
                return false;
            }
            auto xf = openvdb::math::Transform::createLinearTransform(w.voxelSize);
            xf->postTranslate(openvdb::Vec3d(w.translation[0], w.translation[1], w.translation[2]));
            bool clash = false;
            auto fill = [&](auto grid, auto make) {
                using GridT = typename decltype(grid)::element_type;
                auto seen = byName.find(w.name);
                if (seen != byName.end()) {
                    grid = openvdb::gridPtrCast<GridT>(seen->second);
                    if (!grid) {
                        clash = true;
                        return;
                    }
                } else {
                    grid->setName(w.name);
                    grid->setTransform(xf);
                    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
                    out.push_back(grid);
                    byName[w.name] = grid;
                }
                auto acc = grid->getAccessor();
                size_t i = 0;
                for (uint32_t z = 0; z < w.dims[2]; ++z)
                    for (uint32_t y = 0; y < w.dims[1]; ++y)
                        for (uint32_t x = 0; x < w.dims[0]; ++x, ++i)
                            if (w.values[i] != 0.0f)
                                acc.setValue(openvdb::Coord(w.origin[0] + int(x), w.origin[1] + int(y), w.origin[2] + int(z)),
                                             make(w.values[i]));
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
            if (clash) {
                if (error) *error = "grid '" + w.name + "' written as two kinds";
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
