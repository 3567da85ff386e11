//! tide::TextureCache: textures read with OpenImageIO through an ImageCache (any format it
//! reads; tiled / mip-mapped files are cached), converted to linear float.
#pragma once

#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace tide {

/// A texture as handed to the delegate: linear float, row-major from the top row.
struct TextureImage {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::vector<float> pixels;
    /// The file's values were sRGB-encoded and have been linearised.
    bool wasSrgb = false;
};

/// The sRGB transfer function, decoded.
float SrgbToLinear(float v);

class TextureCache {
public:
    TextureCache();
    ~TextureCache();
    TextureCache(const TextureCache&) = delete;
    TextureCache& operator=(const TextureCache&) = delete;

    /// Reads mip level 0 of `path`. `sourceColorSpace`: "raw" keeps values, "sRGB"
    /// linearises, "auto" (or "") linearises 8-bit files and files tagged sRGB. False with
    /// `*error` set if the file cannot be read.
    bool Read(const std::string& path, const std::string& sourceColorSpace, TextureImage* out,
              std::string* error);

    /// True if `path` was already sent with this colour space and is unchanged on disk;
    /// otherwise remembers it as sent.
    bool AlreadySent(const std::string& path, const std::string& sourceColorSpace);
    void ForgetSent(const std::string& path);

private:
    struct Impl;
    Impl* _impl;
};

}  // namespace tide
