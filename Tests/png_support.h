// A PNG decoder for the tests of the program's figures (cli_plot_test, cli_paths_plot_test): 8-bit
// RGB/RGBA/grey, non-interlaced, as gnuplot writes them, decoded with zlib independently of
// gnuplot. Include after <boost/test/unit_test.hpp> and cli_support.h; link ZLIB::ZLIB.
#pragma once

#include <zlib.h>

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace clitest {

struct Image {
    std::uint32_t width = 0, height = 0;
    std::vector<std::array<std::uint8_t, 3>> pixels;  ///< RGB, row by row
    std::size_t count(std::uint32_t rgb) const {
        std::size_t n = 0;
        for (const auto& p : pixels)
            n += ((std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2]) == rgb;
        return n;
    }
    std::size_t distinctColours() const {
        std::set<std::uint32_t> s;
        for (const auto& p : pixels) s.insert((std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2]);
        return s.size();
    }
};

inline std::uint32_t be32(const std::string& s, std::size_t at) {
    return (std::uint32_t(std::uint8_t(s[at])) << 24) | (std::uint32_t(std::uint8_t(s[at + 1])) << 16) |
           (std::uint32_t(std::uint8_t(s[at + 2])) << 8) | std::uint32_t(std::uint8_t(s[at + 3]));
}

/// Decodes `file`; fails the test (BOOST_REQUIRE) if it is not a PNG this decoder reads.
inline Image decodePng(const fs::path& file) {
    const std::string data = readFile(file);
    BOOST_REQUIRE_MESSAGE(data.size() > 33 && data.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0, file << " is not a PNG");
    Image img;
    int colourType = -1, channels = 0;
    std::string idat;
    for (std::size_t at = 8; at + 12 <= data.size();) {
        const std::uint32_t len = be32(data, at);
        const std::string type = data.substr(at + 4, 4);
        if (type == "IHDR") {
            img.width = be32(data, at + 8);
            img.height = be32(data, at + 12);
            BOOST_REQUIRE_EQUAL(int(std::uint8_t(data[at + 16])), 8);  // bit depth
            colourType = std::uint8_t(data[at + 17]);
            BOOST_REQUIRE_EQUAL(int(std::uint8_t(data[at + 20])), 0);  // not interlaced
        } else if (type == "IDAT") {
            idat += data.substr(at + 8, len);
        } else if (type == "IEND") {
            break;
        }
        at += 12 + len;
    }
    channels = colourType == 2 ? 3 : colourType == 6 ? 4 : colourType == 0 ? 1 : colourType == 4 ? 2 : 0;
    BOOST_REQUIRE_MESSAGE(channels > 0, file << ": colour type " << colourType << " not handled by the test decoder");
    const std::size_t stride = std::size_t(img.width) * channels;
    std::vector<std::uint8_t> raw((stride + 1) * img.height);
    uLongf rawSize = raw.size();
    BOOST_REQUIRE_EQUAL(uncompress(raw.data(), &rawSize, reinterpret_cast<const Bytef*>(idat.data()), idat.size()), Z_OK);
    BOOST_REQUIRE_EQUAL(rawSize, raw.size());
    std::vector<std::uint8_t> prev(stride, 0), cur(stride);
    img.pixels.reserve(std::size_t(img.width) * img.height);
    for (std::uint32_t y = 0; y < img.height; ++y) {
        const std::uint8_t filter = raw[y * (stride + 1)];
        const std::uint8_t* line = &raw[y * (stride + 1) + 1];
        for (std::size_t i = 0; i < stride; ++i) {
            const int a = i >= std::size_t(channels) ? cur[i - channels] : 0, b = prev[i],
                      c = i >= std::size_t(channels) ? prev[i - channels] : 0;
            int pred = 0;
            switch (filter) {
                case 0: pred = 0; break;
                case 1: pred = a; break;
                case 2: pred = b; break;
                case 3: pred = (a + b) / 2; break;
                case 4: {
                    const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
                    pred = (pa <= pb && pa <= pc) ? a : pb <= pc ? b : c;
                    break;
                }
                default: BOOST_FAIL("bad PNG filter " << int(filter));
            }
            cur[i] = std::uint8_t(line[i] + pred);
        }
        for (std::uint32_t x = 0; x < img.width; ++x) {
            const std::uint8_t* p = &cur[std::size_t(x) * channels];
            img.pixels.push_back(channels >= 3 ? std::array<std::uint8_t, 3>{p[0], p[1], p[2]}
                                               : std::array<std::uint8_t, 3>{p[0], p[0], p[0]});
        }
        prev.swap(cur);
    }
    return img;
}

}  // namespace clitest
