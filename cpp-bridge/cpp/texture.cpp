//! TextureCache: OpenImageIO reads of whole images (8-bit files as their bytes, 16-bit integer
//! and half-float ones as their codes, others as float), undecoded, into the delegate's memory;
//! each file read once until it changes on disk.
#include "tide/texture.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

namespace tide {

struct TextureCache::Impl {
    std::mutex mutex;
    /// asset → modification time of what was handed to the delegate.
    std::map<std::string, std::filesystem::file_time_type> sent;
};

TextureCache::TextureCache() : _impl(new Impl()) {}

TextureCache::~TextureCache() { delete _impl; }
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

/// OpenImageIO's error text on one line ("a\nb" → "a; b"), or `otherwise` where it is empty.
static std::string OneLine(std::string e, const char* otherwise) {
    while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
    std::string out;
    for (char c : e) {
        if (c == '\n') out += "; ";
        else out += c;
    }
    return out.empty() ? otherwise : out;
}

/// Reads the full-resolution level of the first subimage of `in` into `out` as `format`, a band
/// of rows at a time: memory is taken as rows arrive, so a file whose header claims more pixels
/// than it holds (truncated, corrupt) fails at its first missing row, not after a whole image's
/// worth of memory. The reason on failure, else empty.
static std::string ReadRows(OIIO::ImageInput* in, const OIIO::ImageSpec& spec, OIIO::TypeDesc format,
                            rs::TexelBuffer& out) {
    const size_t row = size_t(spec.width) * size_t(spec.nchannels);
    // bands of about 16 MB, whole tile rows for a tiled file
    const int tile = spec.tile_width > 0 ? std::max(spec.tile_height, 1) : 1;
    int band = int(std::min<size_t>(size_t(spec.height), std::max<size_t>(1, (size_t(16) << 20) / std::max<size_t>(1, row * format.size()))));
    band = std::max(tile, band / tile * tile);
    for (int y = 0; y < spec.height; y += band) {
        const int rows = std::min(band, spec.height - y);
        rust::Slice<uint8_t> dst = out.grow(row * size_t(rows));
        const int y0 = spec.y + y, y1 = spec.y + y + rows;
        const bool ok = spec.tile_width > 0
                            ? in->read_tiles(0, 0, spec.x, spec.x + spec.width, y0, y1, spec.z, spec.z + 1, 0,
                                             spec.nchannels, format, dst.data())
                            : in->read_scanlines(0, 0, y0, y1, spec.z, 0, spec.nchannels, format, dst.data());
        if (!ok) {
            return "rows " + std::to_string(y) + " to " + std::to_string(y + rows - 1) + ": " +
                   OneLine(in->geterror(), "cannot read pixels");
        }
    }
    return "";
}

bool TextureCache::Read(const std::string& path, TextureImage* out, std::string* error) {
    auto fail = [&](const std::string& msg) {
        if (error) *error = msg;
        return false;
    };
    if (path.empty()) return fail("empty asset path");
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return fail("no such file");

    // Pixels as the file stores them: a PNG's alpha is not multiplied into its (still encoded)
    // colour; the delegate decodes the colour and keeps alpha apart.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) return fail(OneLine(OIIO::geterror(), "cannot open image"));
    // the first subimage's full-resolution level
    const OIIO::ImageSpec spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) return fail("image has no pixels");
    if (spec.depth > 1) return fail("volume textures are not supported");
    const double values = double(spec.width) * double(spec.height) * double(spec.nchannels);
    if (values > double(uint64_t(1) << 34)) {
        return fail(std::to_string(spec.width) + "x" + std::to_string(spec.height) + " with " +
                    std::to_string(spec.nchannels) + " channels is over 2^34 values");
    }
    const size_t count = size_t(values);

    TextureImage img;
    img.width = spec.width;
    img.height = spec.height;
    img.channels = spec.nchannels;
    // 8 bits in every channel: kept as bytes (a quarter of the floats' memory); 16-bit integers
    // or half floats in every channel: as their codes (half); anything else as floats
    const bool same = spec.channelformats.empty();
    uint8_t kind = 3;
    OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
    if (same && spec.format == OIIO::TypeDesc::UINT8) {
        kind = 0;
        format = OIIO::TypeDesc::UINT8;
    } else if (same && spec.format == OIIO::TypeDesc::UINT16) {
        kind = 1;
        format = OIIO::TypeDesc::UINT16;
    } else if (same && spec.format == OIIO::TypeDesc::HALF) {
        kind = 2;
        format = OIIO::TypeDesc::HALF;
    }
    std::string why;
    try {
        img.texels.emplace(rs::new_texel_buffer(kind, count));
        why = ReadRows(in.get(), spec, format, **img.texels);
    } catch (const std::exception& e) {
        why = std::string(e.what()) + " (" + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
              " with " + std::to_string(spec.nchannels) + " channels)";
    }
    if (!why.empty()) return fail(why);

    img.isSrgb = spec.format == OIIO::TypeDesc::UINT8 && (spec.nchannels == 3 || spec.nchannels == 4);
    img.wrapmodes = spec.get_string_attribute("wrapmodes");
    *out = std::move(img);
    return true;
}

}  // namespace tide
