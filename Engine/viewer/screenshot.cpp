// crowdhealth-viewer — PNG/PPM writer (see screenshot.h). A PNG is a signature and three chunks
// (IHDR, IDAT with the zlib-compressed rows each prefixed by filter byte 0, IEND), each chunk
// followed by the CRC-32 of its type and data.
#include "screenshot.h"

#include <zlib.h>

#include <cstdio>
#include <fstream>

namespace chviewer {

namespace {

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(v >> s));
}

void chunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
    put32(out, static_cast<std::uint32_t>(data.size()));
    const std::size_t start = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data.begin(), data.end());
    const uLong crc = crc32(0L, out.data() + start, static_cast<uInt>(out.size() - start));
    put32(out, static_cast<std::uint32_t>(crc));
}

}  // namespace

std::string writeImage(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
    if (width <= 0 || height <= 0 || rgb.size() != static_cast<std::size_t>(width) * height * 3)
        return "bad image size";
    std::vector<std::uint8_t> file;
    if (path.size() >= 4 && path.compare(path.size() - 4, 4, ".ppm") == 0) {
        const std::string header = "P6\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
        file.assign(header.begin(), header.end());
        file.insert(file.end(), rgb.begin(), rgb.end());
    } else {
        static const std::uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
        file.assign(sig, sig + 8);
        std::vector<std::uint8_t> ihdr;
        put32(ihdr, static_cast<std::uint32_t>(width));
        put32(ihdr, static_cast<std::uint32_t>(height));
        ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bits, RGB, deflate, no filter method, no interlace
        chunk(file, "IHDR", ihdr);
        std::vector<std::uint8_t> raw;
        raw.reserve(static_cast<std::size_t>(height) * (width * 3 + 1));
        for (int y = 0; y < height; ++y) {
            raw.push_back(0);
            const auto row = rgb.begin() + static_cast<std::ptrdiff_t>(y) * width * 3;
            raw.insert(raw.end(), row, row + width * 3);
        }
        uLongf size = compressBound(static_cast<uLong>(raw.size()));
        std::vector<std::uint8_t> z(size);
        if (compress2(z.data(), &size, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK)
            return "zlib could not compress the image";
        z.resize(size);
        chunk(file, "IDAT", z);
        chunk(file, "IEND", {});
    }
    const std::string tmp = path + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary);
        out.write(reinterpret_cast<const char*>(file.data()), static_cast<std::streamsize>(file.size()));
        if (!out) return "cannot write " + path;
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) return "cannot write " + path;
    return "";
}

}  // namespace chviewer
