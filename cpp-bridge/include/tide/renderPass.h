//! tide::RenderPass: like HdRenderPass, renders the scene into bound render buffers; the
//! rendering itself runs on the Rust delegate's background thread.
#pragma once

#include "rust/cxx.h"
#include "tide-bridge/src/lib.rs.h"

#include <string>
#include <vector>

namespace tide {

class RenderParam;
class RenderBuffer;

/// An AOV (`sourceName`) rendered into a render buffer prim (HdRenderPassAovBinding).
struct RenderPassAovBinding {
    std::string aovName;
    std::string renderBufferId;
    /// Optional: marked converged when the pass is.
    RenderBuffer* renderBuffer = nullptr;
    /// What the buffer holds until the first pass publishes into it, a value per channel
    /// (HdRenderPassAovBinding::clearValue: depth 1, ids -1); empty: zeros.
    std::vector<double> clearValue;
};

/// What a pass renders (the part of HdRenderPassState Tide uses).
struct RenderPassState {
    std::string camera;
    std::vector<RenderPassAovBinding> aovBindings;
    /// A renderSettings prim path, or "" for defaults.
    std::string renderSettings;
    /// The bindings name Hydra's AOVs (HdAovTokens) and want Hydra's layout: rows from the
    /// bottom, `depth` in clip space mapped to [0, 1], ids as int32 in int32 buffers; an AOV
    /// Tide does not render is reported and the rest rendered.
    bool hydra = false;
    /// The host's projection matrix (16 values, GfMatrix4d's order: Hydra's render pass state's,
    /// its framing and window policy in it), whose framing the image takes; empty: the
    /// camera's aperture conformed as the render settings say.
    std::vector<double> projection;
    /// The pass's render tags (HdRenderPass::Execute's): prims whose `renderTag` is not among
    /// them are not rendered; empty renders every prim.
    std::vector<std::string> renderTags;
};

class RenderPass {
public:
    explicit RenderPass(RenderParam* param);
    ~RenderPass();
    RenderPass(const RenderPass&) = delete;
    RenderPass& operator=(const RenderPass&) = delete;

    /// Starts (or restarts) progressive rendering; false with `*error` set if it cannot.
    bool Execute(const RenderPassState& state, std::string* error);
    bool IsConverged() const;
    /// Fraction of the sample target done, in [0, 1].
    double GetProgress() const;
    /// The render's figures after its last finished pass, as `key=value` strings.
    std::vector<std::string> GetSummary() const;
    /// Waits up to `timeoutS` seconds (negative: no limit); true once the pass has stopped.
    bool Wait(double timeoutS) const;
    void Cancel();
    /// The error that stopped the pass, or "".
    std::string GetError() const;

private:
    RenderParam* _param;
    rust::Box<rs::Pass> _pass;
    /// Ids of the buffers the last Execute bound (marked converged through the RenderParam,
    /// which knows whether they still exist).
    std::vector<std::string> _bufferIds;
};

}  // namespace tide
