//! tide::RenderBuffer: a `renderBuffer` bprim shaped like HdRenderBuffer. The Rust delegate
//! owns the pixels; Resolve copies the newest ones here, Map exposes them as float32.
#pragma once

#include "prims.h"

#include <atomic>
#include <mutex>
#include <vector>

namespace tide {

/// A buffer's pixel format: HdFormat's float32 family (the core renders float), and Int32,
/// which holds 32-bit integers (Hydra's id AOVs) in the storage of as many floats: read the
/// mapped pixels as int32_t.
enum class Format { Invalid, Float32, Float32Vec2, Float32Vec3, Float32Vec4, Int32 };

int FormatComponents(Format f);
/// "float", "float2", "float3", "float4", "int32" (HdFormat names without the prefix also
/// accepted).
Format FormatFromName(const std::string& name);

class RenderBuffer final : public Bprim {
public:
    RenderBuffer(const std::string& id, RenderParam* param);
    ~RenderBuffer() override;

    /// Reads `dimensions` (Ints 2) and `format`, then forwards them and allocates.
    void Sync(SceneSource& source, DirtyBits* dirtyBits) override;

    /// Sizes the buffer (depth must be 1); false with a problem if the request is unusable.
    bool Allocate(int width, int height, int depth, Format format, bool multiSampled = false);
    unsigned int GetWidth() const { return _width; }
    unsigned int GetHeight() const { return _height; }
    unsigned int GetDepth() const { return 1; }
    Format GetFormat() const { return _format; }
    bool IsMultiSampled() const { return false; }
    /// Channels of the resolved pixels (the bound AOV's count; the format's before a render).
    int GetChannels() const { return _channels; }

    /// The resolved pixels (float32, or int32 in an Int32 buffer; row-major, from the top row
    /// unless the pass was a Hydra one); call Unmap when done.
    void* Map();
    void Unmap();
    bool IsMapped() const { return _mappers.load() != 0; }
    /// Copies the newest pixels from the renderer. Must not be called while mapped.
    void Resolve();
    bool IsConverged() const { return _converged.load(); }
    void SetConverged(bool converged) { _converged.store(converged); }

private:
    unsigned int _width = 0;
    unsigned int _height = 0;
    int _channels = 0;
    Format _format = Format::Invalid;
    std::vector<float> _pixels;
    std::atomic<int> _mappers{0};
    std::atomic<bool> _converged{false};
};

}  // namespace tide
