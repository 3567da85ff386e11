//! tide::TextureCache: textures read with OpenImageIO (any format it reads; of a tiled or
//! mip-mapped file the full-resolution level), whole, as the values the file holds: 8-bit files
//! as their bytes, 16-bit integer and half-float files as their 16-bit codes, others as float,
//! written straight into the Rust buffer the delegate keeps. A file is read once, again when it changes on disk (the
//! renderer holds every texel of what it reads, so no tile cache is kept beside it). Decoding is
//! the delegate's: each material (or light) decodes by its own `sourceColorSpace`.
#pragma once

#include "rust/cxx.h"
#include "tide-bridge/src/lib.rs.h"

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace tide {

/// A texture as handed to the delegate: the file's values (not decoded), row-major from the top
/// row, in `texels`: bytes for a file of 8 bits in every channel, 16-bit codes for one of 16-bit
/// integers or half floats in every channel, else floats (integers scaled to [0, 1]).
struct TextureImage {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::optional<rust::Box<rs::TexelBuffer>> texels;
    /// Whether `sourceColorSpace = "auto"` reads the file as sRGB-encoded: 8 bits per channel
    /// with 3 or 4 channels, as UsdImaging's image readers decide (other files are raw).
    bool isSrgb = false;
    /// The file's wrap-mode metadata as OpenImageIO reports it ("periodic,clamp"), empty if
    /// the file names none; a UsdUVTexture's `useMetadata` wrap follows it.
    std::string wrapmodes;
};

class TextureCache {
public:
    TextureCache();
    ~TextureCache();
    TextureCache(const TextureCache&) = delete;
    TextureCache& operator=(const TextureCache&) = delete;

    /// Reads mip level 0 of `path`. False with `*error` set if the file cannot be read.
    bool Read(const std::string& path, TextureImage* out, std::string* error);

    /// True if `path` was already sent and is unchanged on disk; otherwise remembers it as
    /// sent.
    bool AlreadySent(const std::string& path);
    void ForgetSent(const std::string& path);

private:
    struct Impl;
    Impl* _impl;
};

}  // namespace tide
