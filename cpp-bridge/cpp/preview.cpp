//! Display previews through OpenColorIO, written as PNG with OpenImageIO.
#include "tide/preview.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

#ifndef TIDE_OCIO_DIR
#define TIDE_OCIO_DIR "ocio"
#endif

namespace OCIO = OCIO_NAMESPACE;

namespace tide {

std::string PreviewConfigPath() {
    if (const char* env = std::getenv("TIDE_OCIO_CONFIG"); env && *env) return env;
    return std::string(TIDE_OCIO_DIR) + "/config.ocio";
}

/// The config's name for a colour space given as the user may spell it.
static std::string CanonicalColorSpace(const std::string& name) {
    std::string n;
    for (char c : name) n += char(std::tolower(static_cast<unsigned char>(c)));
    const std::string suffix = "_scene";
    if (n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0)
        n.resize(n.size() - suffix.size());
    if (n.empty() || n == "scene_linear" || n == "lin_rec709" || n == "linear" || n == "lin_srgb" ||
        n == "linear rec.709 (srgb)" || n == "rec709" || n == "srgb_linear")
        return "lin_rec709";
    if (n == "acescg" || n == "lin_ap1" || n == "aces - acescg") return "ACEScg";
    if (n == "lin_rec2020" || n == "linear rec.2020") return "lin_rec2020";
    return name;
}

bool WritePreviewPng(const std::string& path, int width, int height, int channels, const float* pixels,
                     const std::string& colorSpace, const std::string& view, std::string* error) {
    auto fail = [&](const std::string& msg) {
        if (error) *error = msg;
        return false;
    };
    if (width <= 0 || height <= 0 || channels < 1 || channels > 4 || !pixels)
        return fail("nothing to preview (empty buffer: has the pass rendered?)");

    OCIO::ConstCPUProcessorRcPtr cpu;
    try {
        OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(PreviewConfigPath().c_str());
        OCIO::ConstProcessorRcPtr proc = config->getProcessor(CanonicalColorSpace(colorSpace).c_str(), "sRGB",
                                                              view.empty() ? "Standard" : view.c_str(),
                                                              OCIO::TRANSFORM_DIR_FORWARD);
        cpu = proc->getDefaultCPUProcessor();
    } catch (const std::exception& e) {
        return fail(std::string("OpenColorIO: ") + e.what());
    }

    const std::string tmp = path + ".tmp";
    auto out = OIIO::ImageOutput::create("png");
    if (!out) return fail("OpenImageIO has no PNG writer: " + OIIO::geterror());
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    if (!out->open(tmp, spec)) return fail("cannot open " + tmp + ": " + out->geterror());
    auto abandon = [&](const std::string& msg) {
        out->close();
        std::remove(tmp.c_str());
        return fail(msg);
    };
    // A band of rows at a time through the view transform (RGB, grey for 1 channel, alpha
    // dropped): the preview holds a band, not a second copy of the image.
    const int band = 64;
    std::vector<float> rgb(size_t(width) * size_t(std::min(band, height)) * 3);
    for (int y0 = 0; y0 < height; y0 += band) {
        const int rows = std::min(band, height - y0);
        const size_t n = size_t(width) * size_t(rows);
        const float* src = pixels + size_t(y0) * size_t(width) * size_t(channels);
        for (size_t p = 0; p < n; ++p)
            for (int c = 0; c < 3; ++c) {
                float v = channels >= 3 ? src[p * channels + c] : src[p * channels + std::min(c, channels - 1)];
                rgb[p * 3 + c] = std::isfinite(v) ? v : 0.0f;
            }
        try {
            OCIO::PackedImageDesc desc(rgb.data(), width, rows, 3);
            cpu->apply(desc);
        } catch (const std::exception& e) {
            return abandon(std::string("OpenColorIO: ") + e.what());
        }
        if (!out->write_scanlines(y0, y0 + rows, 0, OIIO::TypeDesc::FLOAT, rgb.data()))
            return abandon("cannot write " + tmp + ": " + out->geterror());
    }
    if (!out->close()) {
        std::remove(tmp.c_str());
        return fail("cannot close " + tmp + ": " + out->geterror());
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::remove(tmp.c_str());
        return fail("cannot rename " + tmp + " to " + path);
    }
    return true;
}

}  // namespace tide
