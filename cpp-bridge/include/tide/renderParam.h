//! tide::RenderParam: the state every prim shares (like HdRenderParam): the Rust delegate,
//! the texture cache and problems found on the C++ side. Forwards values to Rust, turning
//! every Rust error into a recorded problem.
#pragma once

#include "value.h"

#include "rust/cxx.h"
#include "tide-bridge/src/lib.rs.h"

#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace tide {
class RenderBuffer;
class TextureCache;

class RenderParam {
public:
    RenderParam();
    ~RenderParam();
    RenderParam(const RenderParam&) = delete;
    RenderParam& operator=(const RenderParam&) = delete;

    rs::Delegate& GetDelegate() { return *_delegate; }
    TextureCache& GetTextureCache() { return *_textures; }

    /// Sends one sample of `key` on `path` to Rust; false (and a problem) if it was refused.
    bool Forward(const std::string& path, const std::string& key, const TimedValue& value);
    /// Sends a primvar to Rust; false (and a problem) if it was refused.
    bool ForwardPrimvar(const std::string& path, const std::string& name, const Primvar& pv);

    void AddProblem(const std::string& prim, const std::string& attribute, const std::string& message);
    /// The problems recorded on the C++ side since the last call.
    std::vector<Problem> TakeProblems();
    /// Notes that `path` was synced (its problems are found again).
    void NoteSynced(const std::string& path);
    /// The prims synced since the last call.
    std::set<std::string> TakeSynced();

    /// The live render buffers by id: a buffer registers itself while it exists, and a pass
    /// marks the buffers it renders converged through here, so a buffer destroyed while a
    /// pass still holds its binding (an edit removed it before the next Execute) is never
    /// touched.
    void AddBuffer(const std::string& id, RenderBuffer* buffer);
    void RemoveBuffer(const std::string& id, const RenderBuffer* buffer);
    void SetBuffersConverged(const std::vector<std::string>& ids, bool converged);

private:
    rust::Box<rs::Delegate> _delegate;
    std::unique_ptr<TextureCache> _textures;
    std::mutex _problemsMutex;
    std::vector<Problem> _problems;
    std::set<std::string> _synced;
    std::mutex _buffersMutex;
    std::map<std::string, RenderBuffer*> _buffers;
};

}  // namespace tide
