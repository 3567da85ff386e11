//! TextureCache: OpenImageIO ImageCache reads as float, undecoded.
#include "tide/texture.h"

#include <OpenImageIO/imagecache.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace tide {

struct TextureCache::Impl {
    OIIO::ImageCache* cache = nullptr;
    std::mutex mutex;
    /// asset → modification time of what was handed to the delegate.
    std::map<std::string, std::filesystem::file_time_type> sent;
};

TextureCache::TextureCache() : _impl(new Impl()) {
    _impl->cache = OIIO::ImageCache::create(/*shared=*/false);
    _impl->cache->attribute("max_memory_MB", 1024.0f);
    // Keep untiled files readable without holding every scanline file open.
    _impl->cache->attribute("max_open_files", 64);
    // Pixels as the file stores them: a PNG's alpha is not multiplied into its (still encoded)
    // colour; the delegate decodes the colour and keeps alpha apart.
    _impl->cache->attribute("unassociatedalpha", 1);
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

bool TextureCache::AlreadySent(const std::string& path) {
    std::filesystem::file_time_type t{};
    const bool exists = ModificationTime(path, &t);
    std::lock_guard<std::mutex> lock(_impl->mutex);
    auto it = _impl->sent.find(path);
    if (exists && it != _impl->sent.end() && it->second == t) return true;
    if (exists) _impl->sent[path] = t;
    return false;
}

void TextureCache::ForgetSent(const std::string& path) {
    std::lock_guard<std::mutex> lock(_impl->mutex);
    _impl->sent.erase(path);
}

bool TextureCache::Read(const std::string& path, TextureImage* out, std::string* error) {
    auto fail = [&](const std::string& msg) {
        if (error) *error = msg;
        return false;
    };
    if (path.empty()) return fail("empty asset path");
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return fail("no such file");

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

    img.isSrgb = spec.format == OIIO::TypeDesc::UINT8 && (spec.nchannels == 3 || spec.nchannels == 4);
    img.wrapmodes = spec.get_string_attribute("wrapmodes");
    *out = std::move(img);
    return true;
}

}  // namespace tide
