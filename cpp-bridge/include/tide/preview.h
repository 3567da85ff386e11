//! Display previews: a colour buffer through OpenColorIO (the config shipped in
//! cpp-bridge/ocio/) to an 8-bit PNG written with OpenImageIO, atomically.
#pragma once

#include <string>

namespace tide {

/// The OCIO config used: $TIDE_OCIO_CONFIG if set, else the one shipped with the bridge.
std::string PreviewConfigPath();

/// Writes `pixels` (w × h × channels float, channels 1..4, row-major from the top row),
/// which are in `colorSpace` (e.g. "lin_rec709", "ACEScg"), through display "sRGB" and
/// `view` ("Standard" or "Raw") to a PNG at `path`. False with `*error` set on failure.
bool WritePreviewPng(const std::string& path, int width, int height, int channels,
                     const float* pixels, const std::string& colorSpace, const std::string& view,
                     std::string* error);

}  // namespace tide
