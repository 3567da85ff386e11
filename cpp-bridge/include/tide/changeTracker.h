//! tide::ChangeTracker: Hydra-style dirty bits, which attribute dirties what, and per-prim
//! dirty state.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace tide {

using DirtyBits = uint32_t;

/// Dirty bits, named after HdChangeTracker's (and HdMaterial/HdLight/HdCamera's DirtyParams,
/// HdRenderBuffer's DirtyDescription).
class ChangeTracker {
public:
    enum : DirtyBits {
        Clean = 0,
        DirtyTransform = 1u << 1,
        DirtyVisibility = 1u << 2,
        DirtyPoints = 1u << 3,
        DirtyTopology = 1u << 4,
        DirtyPrimvar = 1u << 5,
        DirtyMaterialId = 1u << 6,
        DirtyInstancer = 1u << 7,
        DirtyParams = 1u << 8,
        DirtyResource = 1u << 9,
        DirtyDescription = 1u << 10,
        AllDirty = ~0u,
    };

    /// The bits an edit of attribute `key` dirties on a prim of type `typeId`.
    static DirtyBits BitsForKey(const std::string& typeId, const std::string& key);

    void MarkDirty(const std::string& path, DirtyBits bits);
    DirtyBits GetDirtyBits(const std::string& path) const;
    void MarkClean(const std::string& path);
    void Forget(const std::string& path);
    /// The dirty paths, sorted.
    std::vector<std::string> DirtyPaths() const;

private:
    mutable std::mutex _mutex;
    std::map<std::string, DirtyBits> _bits;
};

}  // namespace tide
