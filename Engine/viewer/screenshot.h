// crowdhealth-viewer — writing an RGB image as PNG (zlib) or binary PPM.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace chviewer {

/// Writes `rgb` (width·height·3 bytes, rows top to bottom) to `path`: binary PPM (P6) when the
/// name ends in ".ppm", PNG otherwise. Returns an error message, empty on success.
std::string writeImage(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb);

}  // namespace chviewer
