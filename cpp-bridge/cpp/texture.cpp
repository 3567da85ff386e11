//! TextureCache: OpenImageIO ImageCache reads converted to linear float.
#include "tide/texture.h"

#include <OpenImageIO/imagecache.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace tide {

float SrgbToLinear(float v) {
    if (v <= 0.04045f) return v / 12.92f;
    return std::pow((v + 0.055f) / 1.055f, 2.4f);
}

struct TextureCache::Impl {
    OIIO::ImageCache* cache = nullptr;
    std::mutex mutex;
    /// asset → (colour space, modification time) of what was handed to the delegate.
    std::map<std::string, std::pair<std::string, std::filesystem::file_time_type>> sent;
};

TextureCache::TextureCache() : _impl(new Impl()) {
    _impl->cache = OIIO::ImageCache::create(/*shared=*/false);
    _impl->cache->attribute("max_memory_MB", 1024.0f);
    // Keep untiled files readable without holding every scanline file open.
    _impl->cache->attribute("max_open_files", 64);
}

TextureCache::~TextureCache() {
    OIIO::ImageCache::destroy(_impl->cache);
    delete _impl;
}

static bool ModificationTime(const std::string& path, std::filesystem::file_time_type* t) {
    std::error_code ec;
    *t = std::filesystem::last_write_time(path, ec);
    return !ec;
}

bool TextureCache::AlreadySent(const std::string& path, const std::string& sourceColorSpace) {
    std::filesystem::file_time_type t{};
    const bool exists = ModificationTime(path, &t);
    std::lock_guard<std::mutex> lock(_impl->mutex);
    auto it = _impl->sent.find(path);
    if (exists && it != _impl->sent.end() && it->second.first == sourceColorSpace && it->second.second == t)
        return true;
    if (exists) _impl->sent[path] = {sourceColorSpace, t};
    return false;
}

void TextureCache::ForgetSent(const std::string& path) {
    std::lock_guard<std::mutex> lock(_impl->mutex);
    _impl->sent.erase(path);
}

bool TextureCache::Read(const std::string& path, const std::string& sourceColorSpace, TextureImage* out,
                        std::string* error) {
    auto fail = [&](const std::string& msg) {
        if (error) *error = msg;
        return false;
    };
    if (path.empty()) return fail("empty asset path");
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return fail("no such file");
    if (sourceColorSpace != "auto" && sourceColorSpace != "" && sourceColorSpace != "raw" &&
        sourceColorSpace != "sRGB")
        return fail("unknown sourceColorSpace '" + sourceColorSpace + "' (auto, raw or sRGB)");

    OIIO::ImageCache* cache = _impl->cache;
    const OIIO::ustring name(path);
    // Re-read a file that changed on disk since it was cached.
    cache->invalidate(name, /*force=*/false);
    OIIO::ImageSpec spec;
    if (!cache->get_imagespec(name, spec, 0, 0)) {
        std::string e = cache->geterror();
        return fail(e.empty() ? "cannot read image" : e);
    }
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) return fail("image has no pixels");
    if (spec.depth > 1) return fail("volume textures are not supported");
    const size_t count = size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels);
    if (count > size_t(std::numeric_limits<int32_t>::max())) return fail("image too large");

    TextureImage img;
    img.width = spec.width;
    img.height = spec.height;
    img.channels = spec.nchannels;
    img.pixels.resize(count);
    if (!cache->get_pixels(name, 0, 0, spec.x, spec.x + spec.width, spec.y, spec.y + spec.height, spec.z,
                           spec.z + 1, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.pixels.data())) {
        std::string e = cache->geterror();
        return fail(e.empty() ? "cannot read pixels" : e);
    }

    const std::string tagged = spec.get_string_attribute("oiio:ColorSpace");
    const bool integer8 = spec.format == OIIO::TypeDesc::UINT8;
    bool srgb = false;
    if (sourceColorSpace == "sRGB") {
        srgb = true;
    } else if (sourceColorSpace != "raw") {
        srgb = OIIO::Strutil::iequals(tagged, "sRGB") || (tagged.empty() && integer8);
    }
    if (srgb) {
        const int alpha = spec.alpha_channel;
        for (size_t p = 0; p < size_t(img.width) * img.height; ++p)
            for (int c = 0; c < img.channels; ++c)
                if (c != alpha) {
                    float& v = img.pixels[p * img.channels + c];
                    v = SrgbToLinear(v);
                }
    }
    img.wasSrgb = srgb;
    *out = std::move(img);
    return true;
}

}  // namespace tide
