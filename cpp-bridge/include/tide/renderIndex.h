//! tide::RenderIndex: a small stand-in for HdRenderIndex used without Hydra (the Python
//! module, tests): owns the prims, tracks dirty bits, syncs dirty prims then commits.
#pragma once

#include "changeTracker.h"
#include "renderDelegate.h"
#include "sceneSource.h"

#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace tide {

class RenderIndex {
public:
    RenderIndex(RenderDelegate* delegate, SceneSource* source);
    ~RenderIndex();
    RenderIndex(const RenderIndex&) = delete;
    RenderIndex& operator=(const RenderIndex&) = delete;

    /// Creates a prim of any kind (rprim, sprim or bprim, by type); replaces an existing
    /// prim at `path`. False for an unknown type (a problem is recorded).
    bool InsertPrim(const std::string& typeId, const std::string& path);
    /// Destroys the prim at `path`; false if there is none.
    bool RemovePrim(const std::string& path);
    bool HasPrim(const std::string& path) const;
    /// The type of the prim at `path`, or "".
    std::string GetPrimType(const std::string& path) const;
    /// Marks `key` on `path` changed.
    void MarkAttributeDirty(const std::string& path, const std::string& key);
    void MarkPrimvarDirty(const std::string& path);
    /// Syncs dirty bprims, sprims, then rprims, then commits.
    void SyncAll();
    RenderBuffer* GetRenderBuffer(const std::string& path) const;
    size_t GetPrimCount() const { return _prims.size(); }

private:
    enum class Kind { R, S, B };
    struct Entry {
        Kind kind;
        Prim* prim;
    };
    void _Destroy(const Entry& e);

    RenderDelegate* _delegate;
    SceneSource* _source;
    ChangeTracker _tracker;
    std::map<std::string, Entry> _prims;
};

}  // namespace tide
